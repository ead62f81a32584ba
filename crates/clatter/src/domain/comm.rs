//! What a domain decomposition needs from its transport ([`Comm`]): a handful of
//! collectives on byte messages. The CLI implements it over MPI (`clatter-cli`, feature
//! `mpi`); [`ThreadComm`] implements it over threads of one process, so the decomposition is
//! tested bitwise by `cargo test` without an MPI installation.

use std::sync::{Arc, Condvar, Mutex};

/// The collectives of a group of ranks. Every rank calls the same methods in the same order
/// (they are collective: a rank that skips one leaves the others waiting).
pub trait Comm {
    /// This rank, `0..size()`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Sends `send[r]` to rank `r` (one message per rank, empty ones included); returns the
    /// message each rank sent here, by rank.
    fn all_to_all(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>>;
    /// [`Comm::all_to_all`] when this rank knows how many bytes each rank sends it
    /// (`recv_len[r]`): the per-step exchange of ghost states, whose sizes follow from the
    /// ghost lists. A transport may then skip exchanging the sizes, and talk only to the
    /// ranks with something to send or receive (MPI: point to point).
    fn all_to_all_known(&self, send: Vec<Vec<u8>>, recv_len: &[usize]) -> Vec<Vec<u8>> {
        let got = self.all_to_all(send);
        debug_assert!(got.iter().map(Vec::len).eq(recv_len.iter().copied()));
        got
    }
    /// [`Comm::all_to_all_known`] between buffers the caller keeps from step to step (the
    /// ghost states of every step): `send[r]` to rank `r`, and rank `r`'s message into
    /// `recv[r]`, whose length is already the number of bytes rank `r` sends here. No
    /// message is allocated nor zeroed per call where the transport writes into `recv`
    /// (MPI); the default goes through [`Comm::all_to_all_known`] and copies.
    fn all_to_all_into(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>]) {
        let len: Vec<usize> = recv.iter().map(Vec::len).collect();
        for (buf, got) in recv
            .iter_mut()
            .zip(self.all_to_all_known(send.to_vec(), &len))
        {
            *buf = got;
        }
    }
    /// [`Comm::all_to_all_into`] and [`Comm::max_f32`] of `x` together: the ghost states
    /// of a step and the largest displacement of any body since the last rebuild (which
    /// decides the next rebuild), so a transport may let the reduction's latency overlap the
    /// exchange's (MPI: a nonblocking all-reduce posted with the point-to-point messages)
    /// rather than wait for one after the other. Returns the maximum of `x` over the ranks.
    fn all_to_all_into_and_max(&self, send: &[Vec<u8>], recv: &mut [Vec<u8>], x: f32) -> f32 {
        self.all_to_all_into(send, recv);
        self.max_f32(x)
    }
    /// [`Comm::all_to_all_into`] with `during` run while the messages travel: the ghost
    /// states of a step sent while the contacts that need no ghost are computed. `during`
    /// is given `progress`, to call now and then (between chunks of its work, on the
    /// calling thread): a transport may need it to move messages along (MPI: `MPI_Test`,
    /// since Open MPI may not move a large message between its own calls). `during` cannot
    /// see `recv` (the call holds it until every message is in).
    /// The default exchanges first and runs `during` after (the blocking order): the same
    /// messages and the same work, so the same results.
    fn all_to_all_into_during(
        &self,
        send: &[Vec<u8>],
        recv: &mut [Vec<u8>],
        during: &mut dyn FnMut(&mut dyn FnMut()),
    ) {
        self.all_to_all_into(send, recv);
        during(&mut || {});
    }
    /// Sends `send[r]` to each rank `r` that `peers[r]` names (every other message must be
    /// empty) and returns what each peer sent here: the bodies and springs of a rebuild
    /// that kept its boxes, between neighbouring ranks. `peers` must be symmetric (rank `r`
    /// names `s` when `s` names `r`). The sizes go first, point to point between the peers
    /// (8 bytes each way), then the messages ([`Comm::all_to_all_known`]): no rank outside
    /// the peers is involved.
    fn exchange_with(&self, send: Vec<Vec<u8>>, peers: &[bool]) -> Vec<Vec<u8>> {
        let me = self.rank();
        debug_assert!(send.iter().zip(peers).all(|(m, &p)| p || m.is_empty()));
        let other = |r: usize| r != me && peers.get(r).copied().unwrap_or(false);
        let sizes: Vec<Vec<u8>> = send
            .iter()
            .enumerate()
            .map(|(r, m)| {
                if other(r) {
                    (m.len() as u64).to_le_bytes().to_vec()
                } else {
                    Vec::new()
                }
            })
            .collect();
        let size_len: Vec<usize> = (0..send.len())
            .map(|r| if other(r) { 8 } else { 0 })
            .collect();
        let got = self.all_to_all_known(sizes, &size_len);
        let len: Vec<usize> = got
            .iter()
            .enumerate()
            .map(|(r, b)| match b.get(..8) {
                Some(b) if other(r) => u64::from_le_bytes(b.try_into().unwrap_or([0; 8])) as usize,
                _ if r == me => send[me].len(),
                _ => 0,
            })
            .collect();
        self.all_to_all_known(send, &len)
    }
    /// Every rank's `mine`, by rank, on every rank.
    fn all_gather(&self, mine: &[u8]) -> Vec<Vec<u8>>;
    /// Every rank's `mine`, by rank, on rank 0 only (the others get nothing): the world
    /// rank 0 writes (frames, checkpoints, the end of a run, `last_good.ckpt` at a blow-up).
    /// The default sends through [`Comm::all_to_all`]; a transport with a gather of its own
    /// (MPI's `Gatherv`) should use it, so that no rank but 0 holds more than its message.
    fn gather_to_root(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        let mut send = vec![Vec::new(); self.size()];
        send[0] = mine.to_vec();
        self.all_to_all(send)
    }
    /// The largest of every rank's `x` (max is exact, so the result does not depend on the
    /// order of reduction).
    fn max_f32(&self, x: f32) -> f32;
    /// The sum of every rank's `x`.
    fn sum_u64(&self, x: u64) -> u64;
    /// The element-wise sum of every rank's `v` (all of the same length), into `v`: the
    /// histograms of the bisection, the exact energy sums of the blow-up checks (integers,
    /// so the sum does not depend on the order). The sums wrap modulo `2^64`, as MPI's sum
    /// of unsigned integers does (the energy sums rely on it for their negative limbs).
    fn sum_u64s(&self, v: &mut [u64]) {
        let mine: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        v.fill(0);
        for m in self.all_gather(&mine) {
            for (x, b) in v.iter_mut().zip(m.chunks_exact(8)) {
                *x = x.wrapping_add(u64::from_le_bytes(b.try_into().unwrap_or([0; 8])));
            }
        }
    }
    /// The element-wise largest of every rank's `v` (all of the same length), into `v`.
    fn max_f32s(&self, v: &mut [f32]) {
        let mine: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        v.fill(f32::NEG_INFINITY);
        for m in self.all_gather(&mine) {
            for (x, b) in v.iter_mut().zip(m.chunks_exact(4)) {
                *x = x.max(f32::from_le_bytes(b.try_into().unwrap_or([0; 4])));
            }
        }
    }
    /// The smallest of every rank's `x`.
    fn min_u64(&self, x: u64) -> u64;
}

/// How a transport whose messages are limited to `limit` bytes (MPI counts are `int`: under
/// 2 GiB) sends larger ones: in rounds, each message cut into pieces of at most
/// `limit / ranks` bytes (so that a round's messages together, which an `Alltoallv` puts in
/// one buffer with `int` offsets, stay within `limit` too). Every rank must take the same
/// number of rounds ([`Rounds::needed`] of the longest message any rank sends or receives).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rounds {
    /// The most bytes of one message in one round.
    pub piece: usize,
}

impl Rounds {
    /// The rounds for `ranks` ranks under a limit of `limit` bytes a round (at least one
    /// byte a piece).
    pub fn new(limit: usize, ranks: usize) -> Rounds {
        Rounds {
            piece: (limit / ranks.max(1)).max(1),
        }
    }

    /// Rounds needed for a message of `len` bytes (one at least, for the empty ones).
    pub fn needed(&self, len: usize) -> usize {
        len.div_ceil(self.piece).max(1)
    }

    /// Round `k`'s piece of `m`: bytes `k * piece..(k + 1) * piece` (empty past its end).
    pub fn piece<'a>(&self, m: &'a [u8], k: usize) -> &'a [u8] {
        let lo = k.saturating_mul(self.piece).min(m.len());
        &m[lo..lo + self.piece_len(m.len(), k)]
    }

    /// The length of round `k`'s piece of a message of `len` bytes.
    pub fn piece_len(&self, len: usize, k: usize) -> usize {
        len.min((k + 1).saturating_mul(self.piece))
            .saturating_sub(k.saturating_mul(self.piece))
    }

    /// An exchange of `send[r]` to each rank `r` whose messages from each rank `r` are
    /// `recv_len[r]` bytes long, in `rounds` rounds (the same on every rank) of `round`
    /// (an exchange of the pieces, given with the lengths of the pieces it receives); the
    /// pieces received are joined back into whole messages.
    pub fn exchange(
        &self,
        send: &[Vec<u8>],
        recv_len: &[usize],
        rounds: usize,
        mut round: impl FnMut(Vec<Vec<u8>>, &[usize]) -> Vec<Vec<u8>>,
    ) -> Vec<Vec<u8>> {
        let mut got: Vec<Vec<u8>> = recv_len.iter().map(|&n| Vec::with_capacity(n)).collect();
        for k in 0..rounds {
            let pieces = send.iter().map(|m| self.piece(m, k).to_vec()).collect();
            let lens: Vec<usize> = recv_len.iter().map(|&n| self.piece_len(n, k)).collect();
            for (g, p) in got.iter_mut().zip(round(pieces, &lens)) {
                g.extend_from_slice(&p);
            }
        }
        got
    }
}

/// The ranks of one process, one thread each (for tests): [`ThreadComm::group`] makes `n`
/// handles, each to be moved into its own thread. With [`ThreadComm::group_limited`], no
/// message between threads is longer than a limit: longer ones go in [`Rounds`], as over
/// MPI (where the limit is `int`'s), so the splitting is tested with a small limit.
pub struct ThreadComm {
    rank: usize,
    shared: Arc<Shared>,
    /// The longest message passed in one piece (`usize::MAX`: any).
    limit: usize,
}

struct Shared {
    size: usize,
    barrier: Gate,
    /// `mail[from][to]`.
    mail: Mutex<Vec<Vec<Vec<u8>>>>,
}

impl ThreadComm {
    /// `n` ranks, one handle per rank.
    pub fn group(n: usize) -> Vec<ThreadComm> {
        Self::group_limited(n, usize::MAX)
    }

    /// `n` ranks whose messages pass in pieces of at most `limit` bytes a round (every
    /// piece is checked: a longer one panics).
    pub fn group_limited(n: usize, limit: usize) -> Vec<ThreadComm> {
        let shared = Arc::new(Shared {
            size: n,
            barrier: Gate::new(n),
            mail: Mutex::new(vec![Vec::new(); n]),
        });
        (0..n)
            .map(|rank| ThreadComm {
                rank,
                shared: shared.clone(),
                limit,
            })
            .collect()
    }

    /// One exchange through the mailbox: `send[r]` to rank `r`, the messages to this rank
    /// back. A round's messages together may not pass the limit.
    fn post(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        assert_eq!(send.len(), self.shared.size, "one message per rank");
        let total: usize = send.iter().map(Vec::len).sum();
        assert!(
            self.limit == usize::MAX || total <= self.limit,
            "{total} bytes in one round, over the limit of {}",
            self.limit
        );
        self.lock()[self.rank] = send;
        self.shared.barrier.wait();
        let got = {
            let mut mail = self.lock();
            (0..self.shared.size)
                .map(|from| std::mem::take(&mut mail[from][self.rank]))
                .collect()
        };
        self.shared.barrier.wait();
        got
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Vec<Vec<u8>>>> {
        // A rank that panicked poisons the lock; the others then panic too (a test failure).
        self.shared.mail.lock().expect("a rank thread panicked")
    }
}

impl Drop for ThreadComm {
    /// A rank whose thread panics drops its handle while unwinding: the gate is broken, so
    /// the ranks waiting for it there (or later) panic too instead of waiting forever, and a
    /// failing test fails instead of hanging.
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.shared.barrier.break_open();
        }
    }
}

/// A barrier for [`ThreadComm`]'s ranks that a panicking rank breaks ([`Gate::break_open`]):
/// `std::sync::Barrier` would keep the others waiting for it forever.
struct Gate {
    size: usize,
    /// Ranks arrived in this generation, the generation, and whether a rank broke it.
    state: Mutex<(usize, u64, bool)>,
    turned: Condvar,
}

impl Gate {
    fn new(size: usize) -> Gate {
        Gate {
            size,
            state: Mutex::new((0, 0, false)),
            turned: Condvar::new(),
        }
    }

    /// Waits until every rank has arrived; panics if a rank panicked (before or meanwhile).
    fn wait(&self) {
        const BROKEN: &str = "another rank thread panicked";
        let mut s = self.state.lock().expect(BROKEN);
        assert!(!s.2, "{BROKEN}");
        let generation = s.1;
        s.0 += 1;
        if s.0 == self.size {
            s.0 = 0;
            s.1 += 1;
            self.turned.notify_all();
            return;
        }
        while s.1 == generation {
            s = self.turned.wait(s).expect(BROKEN);
            assert!(!s.2, "{BROKEN}");
        }
    }

    /// Marks the gate broken and wakes every waiting rank (which then panics).
    fn break_open(&self) {
        if let Ok(mut s) = self.state.lock() {
            s.2 = true;
        }
        self.turned.notify_all();
    }
}

impl Comm for ThreadComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.shared.size
    }

    fn all_to_all(&self, send: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        if self.limit == usize::MAX {
            return self.post(send);
        }
        // The lengths first (8 bytes each), then the rounds every rank agrees on (the most
        // any rank needs), then the pieces.
        let size = self.shared.size;
        let rounds = Rounds::new(self.limit, size);
        let lens = self.post(
            send.iter()
                .map(|m| (m.len() as u64).to_le_bytes().to_vec())
                .collect(),
        );
        let recv_len: Vec<usize> = lens
            .iter()
            .map(|b| u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8])) as usize)
            .collect();
        let mine = send
            .iter()
            .map(Vec::len)
            .chain(recv_len.iter().copied())
            .map(|n| rounds.needed(n))
            .max()
            .unwrap_or(1) as u64;
        let all = self.post(vec![mine.to_le_bytes().to_vec(); size]);
        let n = all
            .iter()
            .map(|b| u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8])))
            .max()
            .unwrap_or(1) as usize;
        rounds.exchange(&send, &recv_len, n, |pieces, lens| {
            let got = self.post(pieces);
            debug_assert!(got.iter().map(Vec::len).eq(lens.iter().copied()));
            got
        })
    }

    fn all_gather(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.all_to_all(vec![mine.to_vec(); self.shared.size])
    }

    fn max_f32(&self, x: f32) -> f32 {
        self.all_gather(&x.to_le_bytes())
            .iter()
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .fold(f32::NEG_INFINITY, f32::max)
    }

    fn sum_u64(&self, x: u64) -> u64 {
        self.all_gather(&x.to_le_bytes())
            .iter()
            .map(|b| u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8])))
            .sum()
    }

    fn min_u64(&self, x: u64) -> u64 {
        self.all_gather(&x.to_le_bytes())
            .iter()
            .map(|b| u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8])))
            .min()
            .unwrap_or(x)
    }
}
