//! Settings schemas: each renderer declares every `key=value` setting once — key, group, one-line
//! doc, type with its range or choices, and how it reads and writes the typed settings struct —
//! and everything that handles settings is derived from that declaration: `--set` parsing, scene
//! and session files, the UI's settings panels, range validation inside the library and the key
//! tables in `docs/settings.md`. The default of a key is whatever the struct's `Default` holds,
//! so it is not stated a second time. Uses only `crate::error`; used by the renderers'
//! settings (`volume::render::settings`, `mesh::settings`, `lpv::settings`), the UI and the demos.

use crate::{Error, Result};

/// A setting's value as the UI and the range checks see it.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// Choice or free-text value.
    Name(String),
    /// Real number.
    Float(f64),
    /// Integer.
    Int(i64),
    /// On/off.
    Bool(bool),
    /// An optional setting that is off (it has no value to show or check).
    Unset,
}

impl Value {
    /// The text the value is written as in `key=value` (booleans as 1/0).
    pub fn text(&self) -> String {
        match self {
            Value::Name(s) => s.clone(),
            // Settings hold f32: print the shortest text that reads back as the same f32.
            Value::Float(f) if f64::from(*f as f32) == *f => format!("{}", *f as f32),
            Value::Float(f) => format!("{f}"),
            Value::Int(i) => format!("{i}"),
            Value::Bool(b) => (if *b { "1" } else { "0" }).to_string(),
            Value::Unset => "off".to_string(),
        }
    }
}

/// An interval of real numbers; infinite ends are unbounded (values must still be finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// `lo` itself is excluded.
    pub lo_open: bool,
    /// `hi` itself is excluded.
    pub hi_open: bool,
}

impl Range {
    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Self { lo, hi, lo_open: false, hi_open: false }
    }
    /// `(lo, hi]`.
    pub const fn above(lo: f64, hi: f64) -> Self {
        Self { lo, hi, lo_open: true, hi_open: false }
    }
    /// `(lo, hi)`.
    pub const fn open(lo: f64, hi: f64) -> Self {
        Self { lo, hi, lo_open: true, hi_open: true }
    }
    /// `[lo, ∞)`.
    pub const fn at_least(lo: f64) -> Self {
        Self::closed(lo, f64::INFINITY)
    }
    /// `(lo, ∞)`.
    pub const fn positive_from(lo: f64) -> Self {
        Self { lo, hi: f64::INFINITY, lo_open: true, hi_open: false }
    }
    /// Any finite number.
    pub const ANY: Self = Self::closed(f64::NEG_INFINITY, f64::INFINITY);

    /// Whether `v` is finite and inside.
    pub fn contains(&self, v: f64) -> bool {
        let lo = if self.lo_open { v > self.lo } else { v >= self.lo };
        let hi = if self.hi_open { v < self.hi } else { v <= self.hi };
        v.is_finite() && lo && hi
    }

    /// Whether the `f32` field value `v` is inside: the bounds are rounded to `f32` first, so a
    /// documented bound such as 1e-6 accepts the `f32` a caller writes as `1e-6`.
    pub fn contains_f32(&self, v: f64) -> bool {
        let round = |b: f64| if b.is_finite() { f64::from(b as f32) } else { b };
        Self { lo: round(self.lo), hi: round(self.hi), ..*self }.contains(v)
    }

    /// Whether every value of `[lo, hi]` is inside (what a slider over that span may produce).
    pub fn covers(&self, lo: f64, hi: f64) -> bool {
        lo <= hi && self.contains(lo) && self.contains(hi)
    }
}

impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.lo.is_finite(), self.hi.is_finite()) {
            (false, false) => write!(f, "finite"),
            (true, false) => write!(f, "finite and {} {}", if self.lo_open { ">" } else { ">=" }, self.lo),
            (false, true) => write!(f, "finite and {} {}", if self.hi_open { "<" } else { "<=" }, self.hi),
            (true, true) => write!(
                f,
                "in {}{}, {}{}",
                if self.lo_open { "(" } else { "[" },
                self.lo,
                self.hi,
                if self.hi_open { ")" } else { "]" }
            ),
        }
    }
}

/// A key's type, its range or choices, and how it reads and writes the settings struct `S`.
pub enum Type<S> {
    /// On/off; written `true`/`false`/`1`/`0`.
    Bool {
        /// Reads the field.
        get: fn(&S) -> bool,
        /// Writes the field.
        set: fn(&mut S, bool),
    },
    /// An integer in `lo..=hi`, a multiple of `step` from `lo`.
    Int {
        /// Smallest value.
        lo: i64,
        /// Largest value.
        hi: i64,
        /// Granularity (grid sizes that must be multiples of 4, …).
        step: i64,
        /// Reads the field.
        get: fn(&S) -> i64,
        /// Writes the field (the value is already in range).
        set: fn(&mut S, i64),
    },
    /// A real number in `range`.
    Float {
        /// Accepted values.
        range: Range,
        /// The UI slider's span when it is not the range itself (an open-ended or vast range);
        /// it must lie inside `range`.
        slider: Option<(f64, f64)>,
        /// Logarithmic slider.
        log: bool,
        /// Reads the field; `None` for an optional setting that is off.
        get: fn(&S) -> Option<f32>,
        /// Writes the field (the value is already in range).
        set: fn(&mut S, f32),
    },
    /// One of `names`.
    Choice {
        /// The accepted names, in UI order.
        names: &'static [&'static str],
        /// Reads the field as one of `names`.
        get: fn(&S) -> &'static str,
        /// Writes the field (the name is one of `names`).
        set: fn(&mut S, &str),
    },
    /// Free text the setter parses (a path, a coordinate list).
    Text {
        /// What the text must look like, for the key table.
        hint: &'static str,
        /// Values the UI offers as a choice (none: the UI does not edit the key).
        presets: &'static [&'static str],
        /// A list of numbers edited by one slider each (`None`: presets or no control).
        sliders: Option<&'static Sliders>,
        /// Reads the field; `None` when off.
        get: fn(&S) -> Option<String>,
        /// Parses and writes the field; the error says what was expected.
        set: fn(&mut S, &str) -> std::result::Result<(), String>,
    },
}

/// The window's sliders of a text key that is a list of numbers or `none` (a crop box, a plane):
/// one per component, and a checkbox that turns the key on (at `initial`) and off (`none`).
#[derive(Debug)]
pub struct Sliders {
    /// Each component's name and slider span, in the text's order.
    pub spans: &'static [(&'static str, f64, f64)],
    /// The value the key takes when the checkbox turns it on, written as the key prints it.
    pub initial: &'static str,
}

/// One setting.
pub struct Key<S: 'static> {
    /// `--set` / scene-file key.
    pub key: &'static str,
    /// Section in the UI panel and in the `docs/settings.md` table.
    pub group: &'static str,
    /// One-line description.
    pub doc: &'static str,
    /// Shown in the UI's settings panel (keys edited elsewhere, e.g. the camera, are not).
    pub ui: bool,
    /// Type, range and field access.
    pub ty: Type<S>,
}

/// Where a setting's text came from, for error messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Origin {
    /// `--set key=value`.
    Cli,
    /// A dedicated command-line flag (`--renderer`).
    Flag(&'static str),
    /// A file's `[settings]` table (scene description or volume session).
    File(String),
}

impl Origin {
    /// How a message names `key=value` from here.
    pub fn describe(&self, key: &str, value: &str) -> String {
        match self {
            Origin::Cli => format!("--set {key}={value}"),
            Origin::Flag(flag) => format!("{flag} {value}"),
            Origin::File(path) => format!("{path}: settings.{key}={value}"),
        }
    }
}

/// A `key=value` pair and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// Key.
    pub key: String,
    /// Value as text (TOML numbers and booleans as they print).
    pub value: String,
    /// Source.
    pub origin: Origin,
}

impl Setting {
    /// A pair from `origin`.
    pub fn new(key: impl Into<String>, value: impl Into<String>, origin: Origin) -> Self {
        Self { key: key.into(), value: value.into(), origin }
    }
}

/// Tags a list of pairs with one origin.
pub fn tagged<'a, I>(pairs: I, origin: &Origin) -> Vec<Setting>
where
    I: IntoIterator<Item = (&'a String, &'a String)>,
{
    pairs.into_iter().map(|(k, v)| Setting::new(k.clone(), v.clone(), origin.clone())).collect()
}

/// A file's settings tagged with `file` as their origin, then command-line `--set` pairs, which
/// come last and so win (the order [`Schema::apply`] reads them in).
pub fn layered(
    file_settings: &std::collections::BTreeMap<String, String>,
    file: &Origin,
    cli: &[(String, String)],
) -> Vec<Setting> {
    let mut all = tagged(file_settings, file);
    all.extend(cli.iter().map(|(k, v)| Setting::new(k.clone(), v.clone(), Origin::Cli)));
    all
}

/// Parses a boolean: `true`/`false`/`1`/`0` (any case for the words).
pub fn parse_bool(text: &str) -> std::result::Result<bool, String> {
    match text.trim().to_ascii_lowercase().as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err("expected true, false, 1 or 0".into()),
    }
}

/// TOML scalars as the text `key=value` parsing reads; `None` for tables and arrays.
pub fn toml_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(x) => Some(x.to_string()),
        toml::Value::Boolean(b) => Some(b.to_string()),
        _ => None,
    }
}

impl<S> Key<S> {
    /// The value `settings` holds.
    pub fn value(&self, settings: &S) -> Value {
        match &self.ty {
            Type::Bool { get, .. } => Value::Bool(get(settings)),
            Type::Int { get, .. } => Value::Int(get(settings)),
            Type::Float { get, .. } => get(settings).map_or(Value::Unset, |v| Value::Float(f64::from(v))),
            Type::Choice { get, .. } => Value::Name(get(settings).to_string()),
            Type::Text { get, .. } => get(settings).map_or(Value::Unset, Value::Name),
        }
    }

    /// Whether `v` is acceptable; the error says what is expected (without naming the key).
    pub fn check(&self, v: &Value) -> std::result::Result<(), String> {
        match (&self.ty, v) {
            (_, Value::Unset) | (Type::Bool { .. }, Value::Bool(_)) | (Type::Text { .. }, Value::Name(_)) => Ok(()),
            (Type::Int { lo, hi, step, .. }, Value::Int(i)) => {
                if !(lo..=hi).contains(&i) {
                    Err(format!("must be in {lo}..={hi}"))
                } else if (i - lo) % step != 0 {
                    Err(format!("must be a multiple of {step} in {lo}..={hi}"))
                } else {
                    Ok(())
                }
            }
            (Type::Float { range, .. }, Value::Float(f)) => {
                if range.contains_f32(*f) {
                    Ok(())
                } else {
                    Err(format!("must be {range}"))
                }
            }
            (Type::Choice { names, .. }, Value::Name(n)) => {
                if names.contains(&n.as_str()) {
                    Ok(())
                } else {
                    Err(format!("expected {}", or_list(names)))
                }
            }
            (_, v) => Err(format!("{v:?} is not a {}", self.type_name())),
        }
    }

    /// Parses `text`, checks it and writes it into `settings`; the error says what was expected.
    pub fn parse_into(&self, settings: &mut S, text: &str) -> std::result::Result<(), String> {
        let t = text.trim();
        match &self.ty {
            Type::Bool { set, .. } => set(settings, parse_bool(t)?),
            Type::Int { set, .. } => {
                let v = t.parse::<i64>().map_err(|_| format!("`{t}` is not an integer"))?;
                self.check(&Value::Int(v))?;
                set(settings, v);
            }
            Type::Float { set, .. } => {
                // Fields are f32: check the value they will actually hold.
                let v = t.parse::<f32>().map_err(|_| format!("`{t}` is not a number"))?;
                self.check(&Value::Float(f64::from(v)))?;
                set(settings, v);
            }
            Type::Choice { set, .. } => {
                self.check(&Value::Name(t.to_string()))?;
                set(settings, t);
            }
            Type::Text { set, .. } => set(settings, t)?,
        }
        Ok(())
    }

    /// Short type description for the key table.
    pub fn type_name(&self) -> String {
        match &self.ty {
            Type::Bool { .. } => "bool".into(),
            Type::Int { lo, hi, step: 1, .. } => format!("int {lo}..={hi}"),
            Type::Int { lo, hi, step, .. } => format!("int {lo}..={hi} step {step}"),
            Type::Float { range, .. } => format!("real, {range}"),
            Type::Choice { names, .. } => names.join(" | "),
            Type::Text { hint, .. } => (*hint).to_string(),
        }
    }
}

fn or_list(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [one] => (*one).to_string(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

/// Every setting of one renderer.
pub struct Schema<S: 'static> {
    /// What the keys configure, for messages (`mesh renderer`).
    pub name: &'static str,
    /// The keys in parts (a part may be shared with another schema through a macro), in the
    /// order they are applied (a preset before the keys that adjust it) and shown.
    pub parts: &'static [&'static [Key<S>]],
}

impl<S> Schema<S> {
    /// Every key, in schema order.
    pub fn keys(&self) -> impl Iterator<Item = &'static Key<S>> + '_ {
        self.parts.iter().flat_map(|p| p.iter())
    }

    /// The key named `key`.
    pub fn key(&self, key: &str) -> Option<&'static Key<S>> {
        self.keys().find(|k| k.key == key)
    }

    /// All key names, in schema order.
    pub fn names(&self) -> Vec<&'static str> {
        self.keys().map(|k| k.key).collect()
    }

    /// Writes `settings` into `target`: every key from its last occurrence (later sources win),
    /// keys in schema order. Unknown keys and bad values are input errors naming their origin.
    pub fn apply(&self, target: &mut S, settings: &[Setting]) -> Result<()> {
        if let Some(s) = settings.iter().find(|s| self.key(&s.key).is_none()) {
            return Err(Error::Input(format!(
                "{}: `{}` is not a setting of the {} (known: {})",
                s.origin.describe(&s.key, &s.value),
                s.key,
                self.name,
                self.names().join(", ")
            )));
        }
        for key in self.keys() {
            if let Some(s) = settings.iter().rev().find(|s| s.key == key.key) {
                key.parse_into(target, &s.value)
                    .map_err(|e| Error::Input(format!("{}: {e}", s.origin.describe(&s.key, &s.value))))?;
            }
        }
        Ok(())
    }

    /// Checks every key's value in `target` against its range: the library's validation, for
    /// settings built in code rather than parsed.
    pub fn check(&self, target: &S) -> Result<()>
    where
        S: Clone,
    {
        for key in self.keys() {
            let v = key.value(target);
            let checked = match (&key.ty, &v) {
                // Free text is checked by its own parser, on a scratch copy.
                (Type::Text { set, .. }, Value::Name(t)) => set(&mut target.clone(), t),
                _ => key.check(&v),
            };
            checked.map_err(|e| Error::Input(format!("{}={}: {e}", key.key, v.text())))?;
        }
        Ok(())
    }

    /// The Markdown key table (key, group, type, default, doc) for `defaults`.
    pub fn markdown(&self, defaults: &S) -> String {
        let mut out = String::from("| key | group | type | default | meaning |\n|---|---|---|---|---|\n");
        for k in self.keys() {
            let d = match k.value(defaults) {
                Value::Unset => "off".to_string(),
                v => v.text(),
            };
            let ty = k.type_name().replace('|', "\\|");
            out.push_str(&format!("| `{}` | {} | {ty} | {d} | {} |\n", k.key, k.group, k.doc));
        }
        out
    }
}

/// Declares a [`Key`] whose value is one field (a place expression of the settings argument):
/// `field!(bool "lpv", "LPV", "doc", |s| s.lpv.enabled)`,
/// `field!(int "lpv_size", "LPV", "doc", 4, 128, 4, |s| s.lpv.size)`,
/// `field!(float "fog_g", "Fog", "doc", Range::closed(-0.99, 0.99), None, false, |s| s.fog.g)`,
/// `field!(choice "tonemap", "Display", "doc", NAMES, ToneMap::parse, ToneMap::name, |s| s.tonemap)`
/// (`parse: fn(&str) -> Option<T>`, `name: fn(T) -> &'static str`),
/// `field!(pair "majorant", "Monte Carlo", "doc", ["global", "grid"], |s| s.mc.majorant_grid)`
/// (a choice of two names over a bool: the first is false, the second true).
/// The UI shows it; `ui: false` keys are written out as struct literals.
#[macro_export]
macro_rules! field {
    (bool $key:literal, $group:literal, $doc:literal, |$s:ident| $place:expr) => {
        $crate::settings::Key {
            key: $key,
            group: $group,
            doc: $doc,
            ui: true,
            ty: $crate::settings::Type::Bool { get: |$s| $place, set: |$s, v| $place = v },
        }
    };
    (int $key:literal, $group:literal, $doc:literal, $lo:expr, $hi:expr, $step:expr, |$s:ident| $place:expr) => {
        $crate::settings::Key {
            key: $key,
            group: $group,
            doc: $doc,
            ui: true,
            ty: $crate::settings::Type::Int {
                lo: $lo,
                hi: $hi,
                step: $step,
                get: |$s| i64::from($place),
                set: |$s, v| {
                    if let Ok(v) = v.try_into() {
                        $place = v;
                    }
                },
            },
        }
    };
    (choice $key:literal, $group:literal, $doc:literal, $names:expr, $parse:path, $name:path, |$s:ident| $place:expr) => {
        $crate::settings::Key {
            key: $key,
            group: $group,
            doc: $doc,
            ui: true,
            ty: $crate::settings::Type::Choice {
                names: $names,
                get: |$s| $name($place),
                set: |$s, n| {
                    if let Some(v) = $parse(n) {
                        $place = v;
                    }
                },
            },
        }
    };
    (pair $key:literal, $group:literal, $doc:literal, [$off:literal, $on:literal], |$s:ident| $place:expr) => {
        $crate::settings::Key {
            key: $key,
            group: $group,
            doc: $doc,
            ui: true,
            ty: $crate::settings::Type::Choice {
                names: &[$off, $on],
                get: |$s| if $place { $on } else { $off },
                set: |$s, n| $place = n == $on,
            },
        }
    };
    (float $key:literal, $group:literal, $doc:literal, $range:expr, $slider:expr, $log:expr, |$s:ident| $place:expr) => {
        $crate::settings::Key {
            key: $key,
            group: $group,
            doc: $doc,
            ui: true,
            ty: $crate::settings::Type::Float {
                range: $range,
                slider: $slider,
                log: $log,
                get: |$s| Some($place),
                set: |$s, v| $place = v,
            },
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn booleans_and_ranges() {
        for (t, b) in [("true", true), ("1", true), ("FALSE", false), ("0", false)] {
            assert_eq!(parse_bool(t), Ok(b));
        }
        assert!(parse_bool("2").is_err() && parse_bool("yes").is_err());
        assert!(Range::above(0.0, 1.0).contains(1.0) && !Range::above(0.0, 1.0).contains(0.0));
        assert!(!Range::ANY.contains(f64::NAN) && !Range::at_least(0.0).contains(f64::INFINITY));
        assert_eq!(Range::above(0.0, 1.0).to_string(), "in (0, 1]");
        assert_eq!(Range::positive_from(0.0).to_string(), "finite and > 0");
    }
}
