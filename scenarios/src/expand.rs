//! Expanding one scenario file into many episodes: `[sweep]` tables (lists of values → cartesian
//! product) and `[random]` tables (seeded random ranges), applied to the file's TOML tree **before**
//! typed deserialisation, so any value of the file can be swept (numbers, strings, whole tables).
//!
//! # Key paths
//! A key path names one value of the tree: keys joined by dots, array elements by index, either
//! as `world.projectiles.0.speed_mps` or `world.projectiles[0].speed_mps`. Every table and array on
//! the way must exist in the file (so a misspelt intermediate key is an error naming the path);
//! the last key may be absent from its table, in which case the value is added (the typed
//! parse then rejects it if it is not a valid key there, again naming the path).
//!
//! # Sweeps
//! ```toml
//! [sweep]
//! "world.projectiles.0.speed_mps" = [6, 9, 12]
//! "world.projectiles.0.texture" = [{ kind = "uniform", luminance = 0.1 }, { kind = "checker" }]
//! ```
//! gives 3 × 2 = 6 parameter points, enumerated like an odometer with the keys in sorted order
//! (the last key changes fastest). Several keys can be varied together (zipped) by listing their
//! paths in one key, separated by commas; each value is then a list with one value per path:
//! ```toml
//! "world.vehicles.0.start, world.vehicles.0.heading_deg" = [[[6.0, 22.0], -90.0], [[6.0, -22.0], 90.0]]
//! ```
//!
//! # Random ranges
//! ```toml
//! [random]
//! samples = 4                                     # draws per sweep point (default 1)
//! "world.projectiles.0.miss_distance_m" = { min = 0.0, max = 1.5 }   # uniform real in [min, max)
//! "world.projectiles.0.radius_m" = { min = 1, max = 3 }              # both integers: uniform integer in [min, max]
//! "world.projectiles.0.launch_azimuth_deg" = { choices = [-10, 0, 10] }  # one of the choices
//! ```
//! Draw `s` (0 ≤ s < samples) uses a ChaCha8 stream seeded from the scenario seed and `s` only, so
//! every sweep point sees the same `samples` draws (a paired design: differences between sweep
//! points are not confounded by different random draws), and the expansion is deterministic.
//!
//! # Episodes
//! Episodes are numbered sweep point (outer) × draw × repeat (inner); their count is
//! `Π len(sweep lists) × samples × episode.repeats`.

use std::collections::BTreeMap;
use std::fmt;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::{Table, Value};

/// Largest number of episodes a suite (or one scenario) may expand to: guards against typos like
/// `samples = 1e9`. Episodes are expanded one at a time as they run, so a large suite costs memory
/// only for the episodes it runs (`loomlab run --limit N` expands N).
pub const MAX_EPISODES_PER_SUITE: usize = 10_000_000;

/// One step of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeySegment {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A parsed key path such as `world.projectiles[0].speed_mps`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyPath(pub Vec<KeySegment>);

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                KeySegment::Key(k) if i == 0 => write!(f, "{k}")?,
                KeySegment::Key(k) => write!(f, ".{k}")?,
                KeySegment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

impl KeyPath {
    /// Parses `a.b.0.c` or `a.b[0].c`. Purely numeric dotted segments are array indices when the
    /// value they step into is an array (decided by [`KeyPath::get`]/[`KeyPath::set`]); here they
    /// are kept as [`KeySegment::Key`] unless written in brackets.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut segments = Vec::new();
        if text.trim().is_empty() {
            return Err("empty key path".into());
        }
        for part in text.split('.') {
            let (name, mut rest) = match part.find('[') {
                Some(i) => (&part[..i], &part[i..]),
                None => (part, ""),
            };
            let name = name.trim();
            if name.is_empty() && (segments.is_empty() || rest.is_empty()) {
                return Err(format!("empty key in key path `{text}`"));
            }
            if !name.is_empty() {
                segments.push(KeySegment::Key(name.to_string()));
            }
            while !rest.is_empty() {
                let close = rest
                    .find(']')
                    .ok_or_else(|| format!("unclosed `[` in key path `{text}`"))?;
                let idx: usize = rest[1..close]
                    .trim()
                    .parse()
                    .map_err(|_| format!("`{}` is not an array index in key path `{text}`", &rest[1..close]))?;
                segments.push(KeySegment::Index(idx));
                rest = &rest[close + 1..];
                if !rest.is_empty() && !rest.starts_with('[') {
                    return Err(format!("unexpected `{rest}` after `]` in key path `{text}`"));
                }
            }
        }
        Ok(Self(segments))
    }

    /// The path with purely numeric keys written as indices (`a.0.b` → `a[0].b`), for comparing
    /// paths written either way.
    pub fn canonical(&self) -> String {
        let segs = self
            .0
            .iter()
            .enumerate()
            .map(|(i, s)| match s {
                KeySegment::Key(k) if i > 0 && !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()) => {
                    k.parse().map_or_else(|_| s.clone(), KeySegment::Index)
                }
                other => other.clone(),
            })
            .collect();
        KeyPath(segs).to_string()
    }

    /// The value at this path, if every step exists.
    pub fn get<'a>(&self, root: &'a Table) -> Option<&'a Value> {
        let mut iter = self.0.iter();
        let KeySegment::Key(first) = iter.next()? else {
            return None;
        };
        let mut cur = root.get(first)?;
        for seg in iter {
            cur = match (seg, cur) {
                (KeySegment::Key(k), Value::Table(t)) => t.get(k)?,
                (KeySegment::Key(k), Value::Array(a)) => a.get(k.parse::<usize>().ok()?)?,
                (KeySegment::Index(i), Value::Array(a)) => a.get(*i)?,
                _ => return None,
            };
        }
        Some(cur)
    }

    /// Sets the value at this path. Every table/array on the way must exist; the last key may be
    /// new in an existing table (array elements must exist). The error says which step failed.
    pub fn set(&self, root: &mut Table, value: Value) -> Result<(), String> {
        let n = self.0.len();
        let KeySegment::Key(first) = &self.0[0] else {
            return Err(format!("key path `{self}` must start with a key"));
        };
        if n == 1 {
            root.insert(first.clone(), value);
            return Ok(());
        }
        let prefix = |i: usize| KeyPath(self.0[..i].to_vec()).to_string();
        let mut cur = root
            .get_mut(first)
            .ok_or_else(|| format!("`{first}` is not in the file (a swept key's tables must exist)"))?;
        for (i, seg) in self.0.iter().enumerate().skip(1) {
            let last = i == n - 1;
            let here = prefix(i);
            cur = match (seg, cur) {
                (KeySegment::Key(k), Value::Table(t)) => {
                    if last {
                        t.insert(k.clone(), value);
                        return Ok(());
                    }
                    t.get_mut(k)
                        .ok_or_else(|| format!("`{here}` has no key `{k}` (a swept key's tables must exist)"))?
                }
                (KeySegment::Key(k), Value::Array(a)) => {
                    let idx: usize = k
                        .parse()
                        .map_err(|_| format!("`{here}` is an array; `{k}` is not an index"))?;
                    let len = a.len();
                    let slot = a
                        .get_mut(idx)
                        .ok_or_else(|| format!("`{here}` has {len} elements; index {idx} does not exist"))?;
                    if last {
                        *slot = value;
                        return Ok(());
                    }
                    slot
                }
                (KeySegment::Index(idx), Value::Array(a)) => {
                    let len = a.len();
                    let slot = a
                        .get_mut(*idx)
                        .ok_or_else(|| format!("`{here}` has {len} elements; index {idx} does not exist"))?;
                    if last {
                        *slot = value;
                        return Ok(());
                    }
                    slot
                }
                (KeySegment::Index(idx), other) => {
                    return Err(format!(
                        "`{here}` is a {}, not an array (index [{idx}])",
                        other.type_str()
                    ));
                }
                (KeySegment::Key(k), other) => {
                    return Err(format!("`{here}` is a {}, not a table (key `{k}`)", other.type_str()));
                }
            };
        }
        unreachable!("the loop returns at the last segment")
    }
}

/// Deep-merges `defaults` under `file`: tables merge key by key (the file wins), any other value
/// (including arrays) in the file replaces the default.
pub fn merge_defaults(file: &mut Table, defaults: &Table) {
    for (k, dv) in defaults {
        match (file.get_mut(k), dv) {
            (Some(Value::Table(ft)), Value::Table(dt)) => merge_defaults(ft, dt),
            (Some(_), _) => {}
            (None, _) => {
                file.insert(k.clone(), dv.clone());
            }
        }
    }
}

/// A random range of `[random]`.
#[derive(Debug, Clone, PartialEq)]
pub enum RandomRange {
    /// Uniform real in [min, max).
    Real {
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// Uniform integer in [min, max].
    Integer {
        /// Lower bound.
        min: i64,
        /// Upper bound (inclusive).
        max: i64,
    },
    /// One of the values, uniformly.
    Choices(Vec<Value>),
}

impl RandomRange {
    fn draw(&self, rng: &mut ChaCha8Rng) -> Value {
        match self {
            Self::Real { min, max } => {
                if max > min {
                    Value::Float(rng.random_range(*min..*max))
                } else {
                    Value::Float(*min)
                }
            }
            Self::Integer { min, max } => Value::Integer(rng.random_range(*min..=*max)),
            Self::Choices(c) => c[rng.random_range(0..c.len())].clone(),
        }
    }
}

/// The `[sweep]` and `[random]` tables of a scenario, parsed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Variation {
    /// Swept keys (one, or several zipped) and their values, in key order. For zipped keys each
    /// value is an array with one element per path.
    pub sweep: Vec<(String, Vec<KeyPath>, Vec<Value>)>,
    /// Randomised keys and their ranges, in key order.
    pub random: Vec<(String, KeyPath, RandomRange)>,
    /// Draws per sweep point.
    pub samples: usize,
}

/// A key error from parsing the variation tables: (key path, reason).
pub type KeyError = (String, String);

fn as_f64(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

impl Variation {
    /// Parses (and removes) `sweep` and `random` from a scenario tree; checks every path exists.
    pub fn take_from(tree: &mut Table) -> Result<Self, KeyError> {
        let mut out = Self {
            samples: 1,
            ..Self::default()
        };
        if let Some(sweep) = tree.remove("sweep") {
            let Value::Table(sweep) = sweep else {
                return Err(("sweep".into(), format!("must be a table, not a {}", sweep.type_str())));
            };
            for (key, values) in sweep {
                let here = format!("sweep.\"{key}\"");
                let paths = key
                    .split(',')
                    .map(|k| KeyPath::parse(k.trim()))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| (here.clone(), e))?;
                let Value::Array(values) = values else {
                    return Err((
                        here,
                        format!("must be a list of values to sweep over, not a {}", values.type_str()),
                    ));
                };
                if values.is_empty() {
                    return Err((here, "the list of values is empty".into()));
                }
                if paths.len() > 1 {
                    for (i, v) in values.iter().enumerate() {
                        if !matches!(v, Value::Array(a) if a.len() == paths.len()) {
                            return Err((
                                format!("{here}[{i}]"),
                                format!(
                                    "zipped keys need a list of {} values (one per key) for every sweep point, got {v}",
                                    paths.len()
                                ),
                            ));
                        }
                    }
                }
                out.sweep.push((key, paths, values));
            }
        }
        if let Some(random) = tree.remove("random") {
            let Value::Table(random) = random else {
                return Err(("random".into(), format!("must be a table, not a {}", random.type_str())));
            };
            for (key, spec) in random {
                if key == "samples" {
                    out.samples = match spec {
                        Value::Integer(n) if n >= 1 => n as usize,
                        other => {
                            return Err((
                                "random.samples".into(),
                                format!("must be an integer >= 1 (draws per sweep point), not {other}"),
                            ));
                        }
                    };
                    continue;
                }
                let here = format!("random.\"{key}\"");
                let path = KeyPath::parse(&key).map_err(|e| (here.clone(), e))?;
                out.random.push((key, path, parse_range(&here, spec)?));
            }
        }
        for (key, path) in out
            .sweep
            .iter()
            .flat_map(|(k, ps, _)| ps.iter().map(move |p| (k, p)))
            .chain(out.random.iter().map(|(k, p, _)| (k, p)))
        {
            let first = matches!(&path.0[0], KeySegment::Key(k) if k == "sweep" || k == "random");
            let episode = path.to_string();
            if first || episode == "episode.seed" || episode == "episode.repeats" {
                return Err((
                    key.clone(),
                    "this key cannot be swept or randomised (it controls the expansion itself)".into(),
                ));
            }
            // Check the path against the file as written (a dry run on a copy).
            let mut probe = tree.clone();
            path.set(&mut probe, Value::Boolean(false))
                .map_err(|e| (key.clone(), format!("cannot vary this key: {e}")))?;
        }
        let varied: Vec<(&String, &KeyPath)> = out
            .sweep
            .iter()
            .flat_map(|(k, ps, _)| ps.iter().map(move |p| (k, p)))
            .chain(out.random.iter().map(|(k, p, _)| (k, p)))
            .collect();
        // Compared in canonical form: `a.0.b` and `a[0].b` name the same value.
        let mut seen = std::collections::HashMap::new();
        for (key, path) in &varied {
            if let Some(first) = seen.insert(path.canonical(), *key) {
                let spelling = if first == *key {
                    String::new()
                } else {
                    format!(" (also as `{first}`: `a.0.b` and `a[0].b` are the same key)")
                };
                return Err((
                    (*key).clone(),
                    format!("this key is varied twice (in [sweep] and/or [random]){spelling}; vary it once"),
                ));
            }
        }
        // A varied key that holds another (`world` and `world.projectiles[0].speed_mps`): setting
        // the outer one replaces the table the inner one lives in.
        let segments = |p: &KeyPath| KeyPath::parse(&p.canonical()).map_or_else(|_| p.0.clone(), |c| c.0);
        for (key, path) in &varied {
            let outer = segments(path);
            if let Some((inner, _)) = varied.iter().find(|(_, p)| {
                let p = segments(p);
                p.len() > outer.len() && p.starts_with(&outer)
            }) {
                return Err((
                    (*key).clone(),
                    format!("this key holds the varied key `{inner}`: vary one or the other, not both"),
                ));
            }
        }
        Ok(out)
    }

    /// Number of parameter points: Π len(sweep lists) × samples (saturating).
    pub fn points(&self) -> usize {
        self.sweep
            .iter()
            .fold(1usize, |acc, (_, _, v)| acc.saturating_mul(v.len()))
            .saturating_mul(self.samples)
    }

    /// The tree of parameter point `index` (0 ≤ index < [`Self::points`]; sweep outer, draw
    /// inner) with the parameters it sets (`key path → TOML value text`). Computed on its own, so
    /// a suite of millions of points is expanded one point at a time.
    pub fn point(&self, base: &Table, seed: u64, index: usize) -> (Table, BTreeMap<String, String>) {
        let samples = self.samples.max(1);
        let (mut sweep_index, draw) = (index / samples, index % samples);
        // the odometer position of `sweep_index` (last key fastest)
        let mut odometer = vec![0usize; self.sweep.len()];
        for (slot, (_, _, values)) in odometer.iter_mut().zip(&self.sweep).rev() {
            *slot = sweep_index % values.len();
            sweep_index /= values.len();
        }
        let mut tree = base.clone();
        let mut params = BTreeMap::new();
        for ((key, paths, values), &i) in self.sweep.iter().zip(&odometer) {
            if let [path] = paths.as_slice() {
                path.set(&mut tree, values[i].clone()).expect("paths were checked");
                params.insert(key.clone(), value_text(&values[i]));
            } else {
                let Value::Array(zipped) = &values[i] else {
                    unreachable!("checked")
                };
                for (path, v) in paths.iter().zip(zipped) {
                    path.set(&mut tree, v.clone()).expect("paths were checked");
                    params.insert(path.to_string(), value_text(v));
                }
            }
        }
        if !self.random.is_empty() {
            let mut rng = ChaCha8Rng::seed_from_u64(mix_seed(seed ^ 0x52414e44, draw as u64));
            for (key, path, range) in &self.random {
                let v = range.draw(&mut rng);
                params.insert(key.clone(), value_text(&v));
                path.set(&mut tree, v).expect("paths were checked");
            }
        }
        (tree, params)
    }

    /// The trees of every parameter point, in order (see [`Self::point`]).
    pub fn expand<'a>(
        &'a self,
        base: &'a Table,
        seed: u64,
    ) -> impl Iterator<Item = (Table, BTreeMap<String, String>)> + 'a {
        (0..self.points()).map(move |i| self.point(base, seed, i))
    }
}

fn parse_range(here: &str, spec: Value) -> Result<RandomRange, KeyError> {
    let Value::Table(t) = spec else {
        return Err((
            here.into(),
            format!(
                "must be a table {{ min = …, max = … }} or {{ choices = [...] }}, not a {}",
                spec.type_str()
            ),
        ));
    };
    for k in t.keys() {
        if !["min", "max", "choices"].contains(&k.as_str()) {
            return Err((
                format!("{here}.{k}"),
                "unknown key (expected `min` and `max`, or `choices`)".into(),
            ));
        }
    }
    match (t.get("min"), t.get("max"), t.get("choices")) {
        (None, None, Some(Value::Array(c))) if !c.is_empty() => Ok(RandomRange::Choices(c.clone())),
        (None, None, Some(_)) => Err((format!("{here}.choices"), "must be a non-empty list".into())),
        (Some(Value::Integer(a)), Some(Value::Integer(b)), None) => {
            if a > b {
                return Err((here.into(), format!("min = {a} is larger than max = {b}")));
            }
            Ok(RandomRange::Integer { min: *a, max: *b })
        }
        (Some(a), Some(b), None) => {
            let (Some(a), Some(b)) = (as_f64(a), as_f64(b)) else {
                return Err((here.into(), "min and max must be numbers".into()));
            };
            if !(a.is_finite() && b.is_finite()) || a > b {
                return Err((here.into(), format!("need finite min <= max, got min = {a}, max = {b}")));
            }
            if !(b - a).is_finite() {
                return Err((
                    here.into(),
                    format!(
                        "the range from min = {a:e} to max = {b:e} is wider than the largest number ({:e}); narrow it",
                        f64::MAX
                    ),
                ));
            }
            Ok(RandomRange::Real { min: a, max: b })
        }
        _ => Err((
            here.into(),
            "give both `min` and `max`, or `choices` (and not both)".into(),
        )),
    }
}

/// A value as compact TOML text (`12`, `0.5`, `"dark"`, `{ kind = "uniform", luminance = 0.1 }`).
pub fn value_text(v: &Value) -> String {
    match v {
        Value::String(s) => format!("{s:?}"),
        Value::Table(t) => {
            let inner: Vec<String> = t.iter().map(|(k, v)| format!("{k} = {}", value_text(v))).collect();
            format!("{{ {} }}", inner.join(", "))
        }
        Value::Array(a) => {
            let inner: Vec<String> = a.iter().map(value_text).collect();
            format!("[{}]", inner.join(", "))
        }
        other => other.to_string(),
    }
}

/// SplitMix64-style mixing of a seed with a stream index (deterministic, well spread).
pub fn mix_seed(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Table {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn key_paths_parse_both_forms() {
        let a = KeyPath::parse("world.projectiles.0.speed_mps").unwrap();
        let b = KeyPath::parse("world.projectiles[0].speed_mps").unwrap();
        assert_eq!(b.to_string(), "world.projectiles[0].speed_mps");
        let t = table("[world]\nprojectiles = [{ speed_mps = 3.0 }]");
        assert_eq!(a.get(&t), Some(&Value::Float(3.0)));
        assert_eq!(b.get(&t), Some(&Value::Float(3.0)));
        assert!(KeyPath::parse("").is_err());
        assert!(KeyPath::parse("a..b").is_err());
        assert!(KeyPath::parse("a[x]").is_err());
        assert!(KeyPath::parse("a[0").is_err());
    }

    #[test]
    fn a_varied_key_holding_another_is_an_error() {
        let text = "[sweep]\nworld = [0.5]\n\"world.projectiles.0.speed_mps\" = [6.0]\n[world]\nprojectiles = [{ speed_mps = 1.0 }]\n";
        let take = |text: &str| Variation::take_from(&mut text.parse::<Table>().unwrap());
        let err = take(text).unwrap_err();
        assert_eq!(err.0, "world");
        assert!(err.1.contains("world.projectiles.0.speed_mps"), "{}", err.1);
        let text = "[random.\"world.ground\"]\nmin = 0.0\nmax = 1.0\n[sweep]\n\"world.ground.friction\" = [0.5]\n[world.ground]\nfriction = 1.0\n";
        assert_eq!(take(text).unwrap_err().0, "world.ground");
    }

    #[test]
    fn set_creates_leaf_but_not_tables() {
        let mut t = table("[world]\nprojectiles = [{ speed_mps = 3.0 }]");
        KeyPath::parse("world.projectiles[0].radius_m")
            .unwrap()
            .set(&mut t, Value::Float(0.2))
            .unwrap();
        assert_eq!(t["world"]["projectiles"][0]["radius_m"], Value::Float(0.2));
        let e = KeyPath::parse("world.camera.n")
            .unwrap()
            .set(&mut t, Value::Integer(3))
            .unwrap_err();
        assert!(e.contains("world") && e.contains("camera"), "{e}");
        let e = KeyPath::parse("world.projectiles[2].speed_mps")
            .unwrap()
            .set(&mut t, Value::Integer(3))
            .unwrap_err();
        assert!(e.contains("1 elements") && e.contains("index 2"), "{e}");
    }

    #[test]
    fn merge_keeps_file_values() {
        let mut f = table("a = 1\n[t]\nx = 1");
        merge_defaults(&mut f, &table("a = 2\nb = 3\n[t]\nx = 2\ny = 2"));
        assert_eq!(f["a"], Value::Integer(1));
        assert_eq!(f["b"], Value::Integer(3));
        assert_eq!(f["t"]["x"], Value::Integer(1));
        assert_eq!(f["t"]["y"], Value::Integer(2));
    }

    #[test]
    fn sweep_and_random_expand_deterministically() {
        let mut t = table(
            r#"
            [world]
            a = 1
            b = "x"
            [sweep]
            "world.a" = [1, 2, 3]
            "world.b" = ["p", "q"]
            [random]
            samples = 4
            "world.c" = { min = 0.0, max = 1.0 }
            "world.d" = { choices = [10, 20] }
            "world.e" = { min = 1, max = 3 }
            "#,
        );
        let v = Variation::take_from(&mut t).unwrap();
        assert!(!t.contains_key("sweep") && !t.contains_key("random"));
        assert_eq!(v.points(), 3 * 2 * 4);
        let all = |seed| v.expand(&t, seed).collect::<Vec<_>>();
        let eps = all(7);
        assert_eq!(eps.len(), 24);
        assert_eq!(eps, all(7), "same seed, same episodes");
        assert_ne!(eps, all(8), "another seed, other draws");
        // any point on its own equals the same point of the whole expansion
        for i in [0, 5, 13, 23] {
            assert_eq!(v.point(&t, 7, i), eps[i]);
        }
        // odometer order: world.a outer, world.b inner, draws innermost
        assert_eq!(eps[0].1["world.a"], "1");
        assert_eq!(eps[0].1["world.b"], "\"p\"");
        assert_eq!(eps[4].1["world.b"], "\"q\"");
        assert_eq!(eps[8].1["world.a"], "2");
        // paired design: draw s is the same at every sweep point
        assert_eq!(eps[1].0["world"]["c"], eps[9].0["world"]["c"]);
        for (tree, _) in &eps {
            let c = tree["world"]["c"].as_float().unwrap();
            assert!((0.0..1.0).contains(&c));
            assert!([10, 20].contains(&tree["world"]["d"].as_integer().unwrap()));
            assert!((1..=3).contains(&tree["world"]["e"].as_integer().unwrap()));
        }
    }

    #[test]
    fn zipped_keys_vary_together() {
        let mut t = table(
            r#"
            [world]
            a = 1
            b = 2
            [sweep]
            "world.a, world.b" = [[1, 10], [2, 20], [3, 30]]
            "#,
        );
        let v = Variation::take_from(&mut t).unwrap();
        let eps: Vec<_> = v.expand(&t, 1).collect();
        assert_eq!(eps.len(), 3);
        for (tree, params) in &eps {
            let a = tree["world"]["a"].as_integer().unwrap();
            assert_eq!(tree["world"]["b"].as_integer().unwrap(), 10 * a);
            assert_eq!(params["world.a"], a.to_string());
        }
        let mut bad = table("[world]\na = 1\nb = 2\n[sweep]\n\"world.a, world.b\" = [[1, 10], [2]]");
        let (k, r) = Variation::take_from(&mut bad).unwrap_err();
        assert!(k.ends_with("[1]") && r.contains("2 values"), "{k}: {r}");
    }

    #[test]
    fn bad_variations_name_the_key() {
        let cases = [
            ("[sweep]\n\"world.a\" = 3", "sweep.\"world.a\"", "list"),
            ("[sweep]\n\"world.a\" = []", "sweep.\"world.a\"", "empty"),
            ("[sweep]\n\"wrld.a\" = [1]", "wrld.a", "not in the file"),
            (
                "[random]\n\"world.a\" = { min = 2, max = 1 }",
                "random.\"world.a\"",
                "larger",
            ),
            ("[random]\n\"world.a\" = { min = 0 }", "random.\"world.a\"", "both"),
            ("[random]\n\"world.a\" = { lo = 0 }", "random.\"world.a\".lo", "unknown"),
            ("[random]\nsamples = 0", "random.samples", ">= 1"),
            ("[sweep]\n\"episode.seed\" = [1, 2]", "episode.seed", "cannot be swept"),
        ];
        for (extra, key, reason) in cases {
            let mut t = table(&format!("[world]\na = 1\n[episode]\nseed = 1\n{extra}"));
            let (k, r) = Variation::take_from(&mut t).unwrap_err();
            assert_eq!(k, key, "{extra}");
            assert!(r.contains(reason), "{extra}: {r}");
        }
    }
}
