//! Solver parameters: one syntax for every solver of the registry (`sor@omega=1.5`,
//! `soft-step@substeps=8,hertz=60`), each solver listing the keys it takes with their defaults
//! and ranges ([`ParamSpec`], in its [`SolverEntry`](super::SolverEntry)), parsed and checked
//! against that list.

use std::fmt;

/// One parameter a solver takes: its key, default, admissible range and meaning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Key in `name@key=value,…` and in a scene's `solver` field.
    pub key: &'static str,
    /// Value when not given.
    pub default: f64,
    /// Smallest admissible value.
    pub min: f64,
    /// Largest admissible value.
    pub max: f64,
    /// True when the value must be a whole number (counts).
    pub integer: bool,
    /// True when the range is open, `(min, max)`: the ends themselves are refused.
    pub open: bool,
    /// What it sets (one line, for `lcpbench solvers`).
    pub doc: &'static str,
}

impl ParamSpec {
    /// A count (substeps, iterations) in `[min, max]`.
    pub const fn count(
        key: &'static str,
        default: usize,
        min: usize,
        max: usize,
        doc: &'static str,
    ) -> Self {
        Self {
            key,
            default: default as f64,
            min: min as f64,
            max: max as f64,
            integer: true,
            open: false,
            doc,
        }
    }

    /// A real value in `[min, max]`.
    pub const fn real(
        key: &'static str,
        default: f64,
        min: f64,
        max: f64,
        doc: &'static str,
    ) -> Self {
        Self {
            key,
            default,
            min,
            max,
            integer: false,
            open: false,
            doc,
        }
    }

    /// A real value in the open interval `(min, max)` (SOR's `omega`, which diverges at the
    /// ends).
    pub const fn real_open(
        key: &'static str,
        default: f64,
        min: f64,
        max: f64,
        doc: &'static str,
    ) -> Self {
        Self {
            key,
            default,
            min,
            max,
            integer: false,
            open: true,
            doc,
        }
    }

    /// The admissible range as text: `[min, max]`, or `(min, max)` for an open one.
    pub fn range(&self) -> String {
        if self.open {
            format!("({}, {})", self.min, self.max)
        } else {
            format!("[{}, {}]", self.min, self.max)
        }
    }

    /// True when `value` lies in the range (and is whole, for a count).
    pub fn admits(&self, value: f64) -> bool {
        self.check(value).is_ok()
    }

    /// Why `value` is refused for this key, if it is.
    fn check(&self, value: f64) -> Result<(), String> {
        let outside = if self.open {
            value <= self.min || value >= self.max
        } else {
            value < self.min || value > self.max
        };
        if !value.is_finite() || outside {
            return Err(format!(
                "{} must be in {}, got {value}",
                self.key,
                self.range()
            ));
        }
        if self.integer && value.fract() != 0.0 {
            return Err(format!("{} must be a whole number, got {value}", self.key));
        }
        Ok(())
    }
}

/// Largest number of parameters a solver takes.
pub const MAX_PARAMS: usize = 16;

/// The parameter values of one solver: its [`ParamSpec`] list and a value for each key.
/// `Copy`, so a solver specification that carries it stays `Copy`.
#[derive(Clone, Copy, PartialEq)]
pub struct Params {
    specs: &'static [ParamSpec],
    values: [f64; MAX_PARAMS],
}

impl Params {
    /// Every key at its default.
    ///
    /// # Panics
    /// When `specs` has more than [`MAX_PARAMS`] entries (a programming error in a solver's
    /// table, caught by the registry's tests and refused by [`super::register`]).
    pub const fn defaults(specs: &'static [ParamSpec]) -> Self {
        assert!(specs.len() <= MAX_PARAMS, "too many solver parameters");
        let mut values = [0.0; MAX_PARAMS];
        let mut k = 0;
        while k < specs.len() {
            values[k] = specs[k].default;
            k += 1;
        }
        Self { specs, values }
    }

    /// The defaults, then `text` (`key=value,key=value`; empty for none) applied over them.
    /// Unknown keys, repeated keys, values that are not numbers and values out of range are
    /// refused with the key and the admissible range named.
    pub fn parse(specs: &'static [ParamSpec], text: &str) -> Result<Self, String> {
        let mut out = Self::defaults(specs);
        let mut seen = [false; MAX_PARAMS];
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((key, value)) = item.split_once('=') else {
                return Err(format!(
                    "`{item}` is not key=value (keys: {})",
                    Self::keys(specs)
                ));
            };
            let (key, value) = (key.trim(), value.trim());
            let Some(k) = specs.iter().position(|s| s.key == key) else {
                return Err(format!(
                    "unknown parameter `{key}` (keys: {})",
                    Self::keys(specs)
                ));
            };
            if seen[k] {
                return Err(format!("parameter `{key}` given twice"));
            }
            seen[k] = true;
            let v: f64 = value
                .parse()
                .map_err(|_| format!("{key}: `{value}` is not a number"))?;
            specs[k].check(v)?;
            out.values[k] = v;
        }
        Ok(out)
    }

    /// The keys of `specs`, comma-separated (`none` when there are none).
    pub fn keys(specs: &[ParamSpec]) -> String {
        if specs.is_empty() {
            return "none".into();
        }
        specs.iter().map(|s| s.key).collect::<Vec<_>>().join(", ")
    }

    /// The specs this set follows.
    pub fn specs(&self) -> &'static [ParamSpec] {
        self.specs
    }

    /// The value of `key`.
    ///
    /// # Panics
    /// When the solver takes no such key (a programming error: solvers ask only for their own
    /// keys).
    pub fn get(&self, key: &str) -> f64 {
        let k = self
            .specs
            .iter()
            .position(|s| s.key == key)
            .unwrap_or_else(|| panic!("solver parameter `{key}` is not in the solver's table"));
        self.values[k]
    }

    /// The value of a count key.
    pub fn count(&self, key: &str) -> usize {
        self.get(key) as usize
    }

    /// Set `key` (checked against its range).
    pub fn set(&mut self, key: &str, value: f64) -> Result<(), String> {
        let k = self
            .specs
            .iter()
            .position(|s| s.key == key)
            .ok_or_else(|| format!("unknown parameter `{key}`"))?;
        self.specs[k].check(value)?;
        self.values[k] = value;
        Ok(())
    }

    /// True when every key is at its default.
    pub fn is_default(&self) -> bool {
        self.specs
            .iter()
            .zip(&self.values)
            .all(|(s, v)| s.default == *v)
    }

    /// Every key with its value, defaults included (`substeps=4,hertz=30,…`).
    pub fn all(&self) -> String {
        self.specs
            .iter()
            .zip(&self.values)
            .map(|(s, v)| format!("{}={v}", s.key))
            .collect::<Vec<_>>()
            .join(",")
    }
}

/// The keys that differ from their defaults, `key=value,…`, in the table's order (empty when
/// all are at their defaults): the form a specification is written back in.
impl fmt::Display for Params {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for (s, v) in self.specs.iter().zip(&self.values) {
            if s.default != *v {
                if !first {
                    out.write_str(",")?;
                }
                write!(out, "{}={v}", s.key)?;
                first = false;
            }
        }
        Ok(())
    }
}

impl fmt::Debug for Params {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(out, "Params({})", self.all())
    }
}

impl std::hash::Hash for Params {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        for (s, v) in self.specs.iter().zip(&self.values) {
            s.key.hash(state);
            v.to_bits().hash(state);
        }
    }
}

impl Eq for Params {}

#[cfg(test)]
mod tests {
    use super::*;

    const SPECS: &[ParamSpec] = &[
        ParamSpec::count("substeps", 4, 1, 64, "substeps per step"),
        ParamSpec::real("hertz", 30.0, 0.0, 1e4, "contact stiffness"),
    ];

    #[test]
    fn parses_checks_and_writes_back() {
        let p = Params::parse(SPECS, "substeps=8, hertz=60").unwrap();
        assert_eq!(p.count("substeps"), 8);
        assert_eq!(p.get("hertz"), 60.0);
        assert_eq!(p.to_string(), "substeps=8,hertz=60");
        let d = Params::parse(SPECS, "").unwrap();
        assert!(d.is_default());
        assert_eq!(d.to_string(), "");
        assert_eq!(Params::parse(SPECS, &p.to_string()).unwrap(), p);
        for bad in [
            "substeps=0",
            "substeps=2.5",
            "substeps=65",
            "hertz=-1",
            "hertz=NaN",
            "omega=1",
            "substeps",
            "substeps=4,substeps=5",
            "hertz=fast",
        ] {
            let e = Params::parse(SPECS, bad).unwrap_err();
            assert!(!e.is_empty(), "{bad}");
        }
        assert!(Params::parse(SPECS, "omega=1")
            .unwrap_err()
            .contains("substeps, hertz"));
    }

    #[test]
    fn an_open_range_refuses_its_ends() {
        const OPEN: &[ParamSpec] = &[ParamSpec::real_open("omega", 1.3, 0.0, 2.0, "relaxation")];
        assert_eq!(Params::parse(OPEN, "omega=1.9").unwrap().get("omega"), 1.9);
        for bad in ["omega=0", "omega=2", "omega=2.5", "omega=-1"] {
            let e = Params::parse(OPEN, bad).unwrap_err();
            assert!(e.contains("omega must be in (0, 2)"), "{bad}: {e}");
        }
        assert!(OPEN[0].admits(1.3) && !OPEN[0].admits(2.0));
    }
}
