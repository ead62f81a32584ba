//! Tuning switches read from the environment (`CLATTER_GPU_*`): a value that is set but not
//! one the switch accepts is not silently taken for the default. The run goes on with the
//! default (a tuning switch changes speed, never results), and stderr says so once per
//! variable and value, naming both, so that a typo in a benchmark script is seen.

use std::collections::HashSet;
use std::sync::Mutex;

/// The value of the environment variable `var` parsed as a `u32`, when it is set and
/// `accept` takes it; `default` otherwise. A set value that does not parse or that `accept`
/// refuses gives `default` and one line on stderr: `clatter: ignoring VAR="VALUE" (expected
/// WHAT; using DEFAULT)`.
pub fn u32_choice(var: &str, expected: &str, accept: impl Fn(u32) -> bool, default: u32) -> u32 {
    let raw = std::env::var_os(var);
    let text = raw.as_ref().map(|r| r.to_string_lossy());
    match parse_choice(text.as_deref(), accept) {
        Ok(v) => v.unwrap_or(default),
        Err(value) => {
            warn_once(var, value, &format!("expected {expected}; using {default}"));
            default
        }
    }
}

/// `Ok(None)` when unset, `Ok(Some(v))` for an accepted value (surrounding blanks allowed),
/// `Err(text)` for a set value that does not parse or is refused.
fn parse_choice(text: Option<&str>, accept: impl Fn(u32) -> bool) -> Result<Option<u32>, &str> {
    match text {
        None => Ok(None),
        Some(t) => match t.trim().parse::<u32>() {
            Ok(v) if accept(v) => Ok(Some(v)),
            _ => Err(t),
        },
    }
}

/// Prints `clatter: ignoring VAR=VALUE (WHY)` on stderr, once per variable and value in
/// this process (worlds are built many times in tests and benchmarks).
fn warn_once(var: &str, value: &str, why: &str) {
    static SEEN: Mutex<Option<HashSet<(String, String)>>> = Mutex::new(None);
    let mut seen = SEEN.lock().unwrap_or_else(|p| p.into_inner());
    if seen
        .get_or_insert_with(HashSet::new)
        .insert((var.to_owned(), value.to_owned()))
    {
        eprintln!("clatter: ignoring {var}={value:?} ({why})");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepted_values_are_taken_and_others_refused() {
        let lanes = |v: u32| v == 0 || v == 8 || v == 16;
        assert_eq!(parse_choice(None, lanes), Ok(None));
        for (value, want) in [("16", Some(16)), (" 0 ", Some(0)), ("8\n", Some(8))] {
            assert_eq!(parse_choice(Some(value), lanes), Ok(want), "{value:?}");
        }
        for value in ["4", "eight", "", "-8", "8.0", "99999999999"] {
            assert_eq!(parse_choice(Some(value), lanes), Err(value), "{value:?}");
        }
    }

    #[test]
    fn an_unset_variable_gives_the_default() {
        let var = "CLATTER_GPU_TEST_ENV_CHOICE_NEVER_SET";
        assert_eq!(u32_choice(var, "0, 8 or 16", |_| true, 8), 8);
    }
}
