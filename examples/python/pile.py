"""Build a scene in code, run it, and plot its energy and the distribution of contact forces.

    python examples/python/pile.py [--out DIR] [--bodies N] [--duration T] [--backend auto|cpu|gpu]

Writes DIR/energy.png (kinetic, potential and total energy over time) and
DIR/contact_forces.png (a histogram of the normal contact forces at the end), DIR/scene.toml
(the scene as a file `clatter run` reads) and prints where they went.
"""

import argparse
import os
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("pile.py needs matplotlib for its plots: python3 -m pip install './python[examples]' (or python3 -m pip install matplotlib)")

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt
import numpy as np

import clatter


def build_scene(bodies: int, duration: float) -> clatter.Scene:
    side = int(np.ceil(np.sqrt(bodies / 3)))
    spacing = 0.016
    top = 0.012 + spacing * (int(np.ceil(bodies / side**2)) - 1)
    return (
        clatter.Scene(duration=duration)
        .material("plastic", density=1200.0, stiffness=2.0e3, restitution=0.5, friction=0.4)
        .shape("cube", polyhedron={"kind": "cube", "radius": 0.006})
        .shape("bead", sphere=0.005)
        .container(min=[0, 0, 0], max=[side * spacing + 0.01] * 2 + [0.2], material="plastic", top=False)
        .group("cube", "plastic", random_orientation=True,
               lattice=dict(min=[0.01, 0.01, 0.012], max=[0.01 + spacing * (side - 1)] * 2 + [top], spacing=spacing))
        .group("bead", "plastic", random=dict(min=[0.01, 0.01, top + 0.02], max=[0.01 + spacing * (side - 1)] * 2 + [top + 0.06],
                                              count=max(1, bodies // 3), seed=5))
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="clatter-out/python-pile")
    ap.add_argument("--bodies", type=int, default=300, help="about this many bodies (whole lattice layers of cubes, then beads)")
    ap.add_argument("--duration", type=float, default=0.3)
    ap.add_argument("--backend", default="auto")
    args = ap.parse_args()

    scene = build_scene(args.bodies, args.duration)
    os.makedirs(args.out, exist_ok=True)
    scene.save(os.path.join(args.out, "scene.toml"))
    sim = clatter.Simulation(scene, backend=args.backend)
    print(f"{sim.n_bodies} bodies, dt = {sim.dt:.3e} s, {scene.steps} steps, backend {sim.backend_reason}")

    samples = 100
    every = max(1, scene.steps // samples)
    t, kinetic, potential = [sim.time], [sim.kinetic_energy()], [sim.potential_energy()]
    while sim.step_count < scene.steps:
        sim.step(min(every, scene.steps - sim.step_count))
        t.append(sim.time)
        kinetic.append(sim.kinetic_energy())
        potential.append(sim.potential_energy())
    kinetic, potential = np.array(kinetic), np.array(potential)

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(t, kinetic, label="kinetic")
    ax.plot(t, potential - potential.min(), label="potential (above its minimum)")
    ax.plot(t, kinetic + potential - potential.min(), label="total", color="k", lw=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy (J)")
    ax.set_title(f"{sim.n_bodies} bodies settling: energy")
    ax.legend()
    fig.tight_layout()
    energy_png = os.path.join(args.out, "energy.png")
    fig.savefig(energy_png, dpi=120)

    contacts = sim.contacts()
    f = contacts["normal_force"]
    fig, ax = plt.subplots(figsize=(7, 4))
    walls = contacts["wall"] >= 0
    bins = np.linspace(0, max(float(f.max()) if len(f) else 1.0, 1e-9), 40)
    ax.hist([f[~walls], f[walls]], bins=bins, stacked=True, label=["body-body", "body-wall"])
    ax.set_yscale("log")
    ax.set_xlabel("normal contact force (N)")
    ax.set_ylabel("contacts")
    ax.set_title(f"contact forces at t = {sim.time:.3f} s ({len(f)} contacts)")
    ax.legend()
    fig.tight_layout()
    forces_png = os.path.join(args.out, "contact_forces.png")
    fig.savefig(forces_png, dpi=120)
    print(f"wrote {energy_png} and {forces_png}")


if __name__ == "__main__":
    main()
