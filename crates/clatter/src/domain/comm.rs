//! What a domain decomposition needs from its transport ([`Comm`]): a handful of
//! collectives on byte messages. The CLI implements it over MPI (`clatter-cli`, feature
//! `mpi`); [`ThreadComm`] implements it over threads of one process, so the decomposition is
//! tested bitwise by `cargo test` without an MPI installation.

use std::sync::{Arc, Barrier, Mutex};

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
    /// Every rank's `mine`, by rank, on rank 0 only (the others get nothing): the last good
    /// state gathered for `last_good.ckpt` at a blow-up.
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

/// The ranks of one process, one thread each (for tests): [`ThreadComm::group`] makes `n`
/// handles, each to be moved into its own thread.
pub struct ThreadComm {
    rank: usize,
    shared: Arc<Shared>,
}

struct Shared {
    size: usize,
    barrier: Barrier,
    /// `mail[from][to]`.
    mail: Mutex<Vec<Vec<Vec<u8>>>>,
}

impl ThreadComm {
    /// `n` ranks, one handle per rank.
    pub fn group(n: usize) -> Vec<ThreadComm> {
        let shared = Arc::new(Shared {
            size: n,
            barrier: Barrier::new(n),
            mail: Mutex::new(vec![Vec::new(); n]),
        });
        (0..n)
            .map(|rank| ThreadComm {
                rank,
                shared: shared.clone(),
            })
            .collect()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Vec<Vec<u8>>>> {
        // A rank that panicked poisons the lock; the others then panic too (a test failure).
        self.shared.mail.lock().expect("a rank thread panicked")
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
        assert_eq!(send.len(), self.shared.size, "one message per rank");
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
