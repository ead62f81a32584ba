//! Published curves of Chung & Ooi tests 4-8 as small CSV tables (`data/*.csv`), compiled in.
//! Each file's header says where its numbers come from (repository, path, commit, figure).

/// One digitised curve: `(x, y)` points in the order of the source.
#[derive(Clone, Debug, Default)]
pub struct Curve {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

/// A table: `series,x,y` rows after `#` comment lines and the header line.
pub struct Table {
    /// The file name (for messages).
    pub file: &'static str,
    rows: Vec<(String, f64, f64)>,
}

impl Table {
    /// Parses `text` (the contents of `file`).
    pub fn parse(file: &'static str, text: &str) -> anyhow::Result<Table> {
        let mut rows = Vec::new();
        for (k, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line == "series,x,y" {
                continue;
            }
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            let [name, x, y] = cells[..] else {
                anyhow::bail!("{file}:{}: expected `series,x,y`, got {line:?}", k + 1);
            };
            let num = |s: &str| -> anyhow::Result<f64> {
                s.parse()
                    .map_err(|e| anyhow::anyhow!("{file}:{}: {s:?}: {e}", k + 1))
            };
            rows.push((name.to_string(), num(x)?, num(y)?));
        }
        Ok(Table { file, rows })
    }

    /// The points of one series (an error when the table has none).
    pub fn series(&self, name: &str) -> anyhow::Result<Curve> {
        let mut c = Curve::default();
        for (n, x, y) in &self.rows {
            if n == name {
                c.x.push(*x);
                c.y.push(*y);
            }
        }
        anyhow::ensure!(!c.x.is_empty(), "{}: no series {name:?}", self.file);
        Ok(c)
    }
}

/// A compiled-in table of `data/`.
macro_rules! table {
    ($file:literal) => {
        $crate::validate::chung_ooi::data::Table::parse(
            $file,
            include_str!(concat!("data/", $file)),
        )
    };
}
pub(crate) use table;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_table_parses_with_its_series() {
        let all = [
            (
                table!("test4_tangential_restitution.csv"),
                &["oxide", "alloy", "kharaz"][..],
            ),
            (
                table!("test4_angular_velocity.csv"),
                &["oxide", "alloy", "kharaz"][..],
            ),
            (
                table!("test4_rebound_angle.csv"),
                &["oxide", "alloy", "kharaz"][..],
            ),
            (
                table!("test5_rebound_angle.csv"),
                &["steel", "polyethylene", "fem"][..],
            ),
            (
                table!("test5_angular_velocity.csv"),
                &["steel", "polyethylene", "fem"][..],
            ),
            (table!("test6_beta.csv"), &["alloy", "nylon"][..]),
            (table!("test6_recoil.csv"), &["alloy", "nylon"][..]),
            (table!("test8_beta.csv"), &["alloy", "nylon", "test6"][..]),
            (table!("test8_recoil.csv"), &["alloy", "nylon", "test6"][..]),
        ];
        for (t, names) in all {
            let t = t.expect("parses");
            for n in names {
                assert!(t.series(n).expect("series").x.len() >= 10, "{} {n}", t.file);
            }
        }
    }

    #[test]
    fn malformed_rows_are_errors() {
        assert!(Table::parse("x.csv", "a,1\n").is_err());
        assert!(Table::parse("x.csv", "a,1,zz\n").is_err());
        assert!(
            Table::parse("x.csv", "a,1,2\n")
                .expect("ok")
                .series("b")
                .is_err()
        );
    }
}
