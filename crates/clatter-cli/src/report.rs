//! Blow-up reports: the error a run, render or view stopped by a blow-up returns, and the exit
//! status `main` gives it.

/// Exit status of a run stopped by a blow-up (1 is any other error, 2 a usage error).
pub const BLOW_UP_EXIT: u8 = 3;

/// A run stopped by a blow-up; `main` exits with [`BLOW_UP_EXIT`].
#[derive(Debug)]
pub struct BlownUp(pub String);

impl std::fmt::Display for BlownUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BlownUp {}
