//! Settings panels derived from a renderer's settings schema (`crate::settings`). A control shows
//! the value the parsed settings hold and, when moved, emits a new `key=value`; the demo re-parses
//! its whole setting list through the same schema the CLI and scene files use, so every change
//! the UI can make is one a saved scene file reproduces exactly.

use egui::Ui;

/// How a setting is edited.
#[derive(Clone, Copy, Debug)]
pub enum Kind {
    /// One of these names.
    Choice(&'static [&'static str]),
    /// A real number in [lo, hi], logarithmic slider when `log`.
    Float {
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
        /// Logarithmic slider.
        log: bool,
    },
    /// An integer in [lo, hi], in steps of `step` from `lo`.
    Int {
        /// Lower bound.
        lo: i64,
        /// Upper bound.
        hi: i64,
        /// Granularity (grid sizes that must be multiples of 4, …).
        step: i64,
    },
    /// On/off, written as 1/0.
    Toggle,
    /// A list of numbers or `none`: a checkbox and one slider per component.
    Sliders(&'static Sliders),
}

pub use crate::settings::Value;
use crate::settings::{Key, Schema, Sliders, Type};

/// The widget a key gets, derived from its schema type: `None` for keys the panel does not
/// show (`ui: false`) and free text without presets.
pub fn kind<S>(key: &Key<S>) -> Option<Kind> {
    if !key.ui {
        return None;
    }
    Some(match &key.ty {
        Type::Bool { .. } => Kind::Toggle,
        Type::Int { lo, hi, step, .. } => Kind::Int { lo: *lo, hi: *hi, step: *step },
        Type::Float { range, slider, log, .. } => {
            let (lo, hi) = slider.unwrap_or((range.lo, range.hi));
            Kind::Float { lo, hi, log: *log }
        }
        Type::Choice { names, .. } => Kind::Choice(names),
        Type::Text { sliders: Some(s), .. } => Kind::Sliders(s),
        Type::Text { presets: [], .. } => return None,
        Type::Text { presets, .. } => Kind::Choice(presets),
    })
}

/// The panel's controls: every key of `schema` that has a widget, in schema order.
pub fn controls<S>(schema: &Schema<S>) -> Vec<(&'static Key<S>, Kind)> {
    schema.keys().filter_map(|k| kind(k).map(|kind| (k, kind))).collect()
}

/// The text a value is written as in `key=value`.
pub fn format_value(v: &Value) -> String {
    v.text()
}

/// Draws one control; returns the new `key=value` when the user changed it.
fn show<S>(ui: &mut Ui, c: &Key<S>, kind: Kind, settings: &S) -> Option<(String, String)> {
    let current = c.value(settings);
    let changed = match (kind, &current) {
        (Kind::Choice(names), Value::Name(now)) => {
            let mut pick = now.clone();
            let r = egui::ComboBox::from_label(c.key).selected_text(pick.clone()).show_ui(ui, |ui| {
                for n in names {
                    let r = ui.selectable_value(&mut pick, n.to_string(), *n);
                    super::track(&r, &format!("{}:{n}", c.key));
                }
            });
            super::track(&r.response, c.key);
            (pick != *now).then_some(Value::Name(pick))
        }
        (Kind::Float { lo, hi, log }, Value::Float(now)) => {
            let mut v = *now;
            let r = ui.add(egui::Slider::new(&mut v, lo..=hi).logarithmic(log).text(c.key));
            super::track(&r, c.key);
            (r.changed() && v != *now).then_some(Value::Float(v))
        }
        (Kind::Int { lo, hi, step }, Value::Int(now)) => {
            let mut v = *now;
            let r = ui.add(egui::Slider::new(&mut v, lo..=hi).step_by(step as f64).text(c.key));
            super::track(&r, c.key);
            (r.changed() && v != *now).then_some(Value::Int(v))
        }
        (Kind::Toggle, Value::Bool(now)) => {
            let mut v = *now;
            let r = ui.checkbox(&mut v, c.key);
            super::track(&r, c.key);
            (v != *now).then_some(Value::Bool(v))
        }
        (Kind::Sliders(sl), Value::Name(now)) => {
            let numbers = |t: &str| t.split(',').filter_map(|p| p.trim().parse::<f32>().ok()).collect::<Vec<_>>();
            let was_on = now != "none";
            let mut on = was_on;
            let r = ui.checkbox(&mut on, c.key);
            super::track(&r, c.key);
            let mut v = numbers(if on && was_on { now } else { sl.initial });
            if on {
                for ((name, lo, hi), x) in sl.spans.iter().zip(v.iter_mut()) {
                    let r = ui.add(egui::Slider::new(x, *lo as f32..=*hi as f32).text(format!("{} {name}", c.key)));
                    super::track(&r, &format!("{}:{name}", c.key));
                }
            }
            let text = if on { v.iter().map(f32::to_string).collect::<Vec<_>>().join(",") } else { "none".into() };
            (text != *now).then_some(Value::Name(text))
        }
        (kind, v) => {
            ui.label(format!("{}: {v:?} does not fit {kind:?}", c.key));
            None
        }
    };
    changed.map(|v| (c.key.to_string(), format_value(&v)))
}

/// Draws every control of `table` grouped in collapsible sections (open: `open_groups`);
/// returns the changes made this frame.
pub fn panel<S>(ui: &mut Ui, schema: &Schema<S>, settings: &S, open_groups: &[&str]) -> Vec<(String, String)> {
    let table = controls(schema);
    let mut groups: Vec<&str> = Vec::new();
    for (c, _) in &table {
        if !groups.contains(&c.group) {
            groups.push(c.group);
        }
    }
    let mut changes = Vec::new();
    for group in groups {
        let r = egui::CollapsingHeader::new(group).default_open(open_groups.contains(&group)).show(ui, |ui| {
            for (c, kind) in table.iter().filter(|(c, _)| c.group == group) {
                changes.extend(show(ui, c, *kind, settings));
            }
        });
        super::track(&r.header_response, group); // scripts open a group by its name
    }
    changes
}

/// Replaces (or adds) `key` in a setting list, keeping one entry per key.
pub fn upsert(sets: &mut Vec<(String, String)>, key: &str, value: &str) {
    sets.retain(|(k, _)| k != key);
    sets.push((key.to_string(), value.to_string()));
}

/// A valid value of `kind` different from `now`: what the schema tests move each control to
/// before checking that the parser reads it back.
pub fn moved(key: &str, kind: Kind, now: &Value) -> Value {
    match (kind, now) {
        (Kind::Choice(names), Value::Name(n)) => {
            Value::Name(names.iter().find(|x| **x != n).expect("two choices").to_string())
        }
        (Kind::Float { lo, hi, .. }, Value::Float(v)) => {
            let x = lo + 0.37 * (hi - lo);
            Value::Float(if (x - v).abs() > 1e-6 { x as f32 as f64 } else { hi as f32 as f64 })
        }
        (Kind::Int { lo, step, .. }, Value::Int(v)) => {
            Value::Int(if *v == lo + step { lo + 2 * step } else { lo + step })
        }
        (Kind::Toggle, Value::Bool(b)) => Value::Bool(!b),
        (Kind::Sliders(s), Value::Name(n)) => Value::Name(if n == "none" { s.initial } else { "none" }.to_string()),
        (k, v) => panic!("{key}: {v:?} does not fit {k:?}"),
    }
}
