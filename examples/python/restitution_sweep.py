"""Parameter sweep: the coefficient of restitution asked for vs the rebound measured.

    python examples/python/restitution_sweep.py [--out DIR]

Drops a sphere on a floor for each restitution e, measures the speed just before and just
after the bounce, and plots measured vs requested (the line e_measured = e is where the
spring-dashpot's damping, derived from e, should put them). Writes DIR/restitution.png and
DIR/restitution.csv.
"""

import argparse
import math
import os
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("restitution_sweep.py needs matplotlib for its plot: python3 -m pip install './python[examples]' (or python3 -m pip install matplotlib)")

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import clatter

RADIUS, HEIGHT = 0.01, 0.05


def rebound(e: float, model: str = "linear") -> float:
    """Measured restitution: rebound speed over impact speed for one drop."""
    scene = clatter.Scene(steps=1, dt=1e-5, gravity=[0, 0, -9.81])
    if model == "linear":
        scene.material("steel", density=7800.0, stiffness=1e5, restitution=e)
    else:
        scene.material("steel", density=7800.0, model="hertz", youngs_modulus=1e8, poisson_ratio=0.3, restitution=e)
    scene.shape("ball", sphere=RADIUS).wall([0, 0, 0], [0, 0, 1], "steel").body("ball", "steel", [0, 0, RADIUS + HEIGHT])
    sim = clatter.Simulation(scene, backend="cpu", threads=1)
    v_in = 0.0
    while True:
        sim.step(5)
        vz = float(sim.velocities[0, 2])
        if vz < 0 and len(sim.contacts()["body"]) == 0:
            v_in = -vz  # the last speed before touching the floor
        elif vz > 0 and len(sim.contacts()["body"]) == 0:
            return vz / v_in
        if sim.time > 1.0:
            raise RuntimeError(f"e = {e}: no rebound within 1 s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="clatter-out/python-restitution")
    ap.add_argument("--points", type=int, default=9)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    asked = np.linspace(0.1, 0.95, args.points)
    linear = np.array([rebound(e, "linear") for e in asked])
    hertz = np.array([rebound(e, "hertz") for e in asked])
    np.savetxt(os.path.join(args.out, "restitution.csv"), np.c_[asked, linear, hertz], delimiter=",",
               header="requested,measured_linear,measured_hertz", comments="")

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot([0, 1], [0, 1], "k--", lw=1, label="measured = requested")
    ax.plot(asked, linear, "o", label="linear spring-dashpot")
    ax.plot(asked, hertz, "s", mfc="none", label="Hertz")
    ax.set_xlabel("requested restitution e")
    ax.set_ylabel("measured rebound / impact speed")
    ax.set_title(f"sphere dropped from {HEIGHT * 100:.0f} cm")
    ax.legend()
    fig.tight_layout()
    png = os.path.join(args.out, "restitution.png")
    fig.savefig(png, dpi=120)
    print("e asked   linear   hertz")
    for a, l, h in zip(asked, linear, hertz):
        print(f"{a:7.3f}  {l:7.3f}  {h:6.3f}")
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
