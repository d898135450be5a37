//! Technique parameters as typed data. Each technique declares two `serde` structs — its bake
//! parameters (part of the cache key: the hash of their canonical serialisation) and its draw
//! parameters (never re-bake) — each implementing [`ParamTable`]: defaults, one [`ParamDoc`]
//! per key and range checks. Settings from the scene file (`[technique.NAME]`, `[[lod.band]]`
//! tables) and the command line (`--set NAME.key=value`) are applied over the defaults in that
//! order by [`resolve`]; a key neither struct has, a value of the wrong type or out of range is
//! one line naming the place, the key and the nearest valid key.

use crate::RenderError;
use serde::Serialize;
use serde::de::DeserializeOwned;
use sylvan_scene::{ParamValue, Setting};

/// One key's documentation.
#[derive(Debug, Clone, Copy)]
pub struct ParamDoc {
    /// The key, as in the scene file and `--set`.
    pub key: &'static str,
    /// Its unit (`px`, `m`, `texels`, `directions`; empty when it has none).
    pub unit: &'static str,
    /// One line saying what it does.
    pub doc: &'static str,
}

/// A parameter struct: `serde` with `#[serde(default, deny_unknown_fields)]`, one doc per key.
pub trait ParamTable:
    Serialize + DeserializeOwned + Default + Clone + PartialEq + std::fmt::Debug
{
    /// One entry per key (checked against the serialised keys by a test).
    const DOCS: &'static [ParamDoc];
    /// Checks ranges; the message starts with the key and says what is valid, e.g.
    /// `"levels 4: must be 1, 2 or 3"`.
    fn validate(&self) -> Result<(), String>;
}

/// A technique without parameters of a kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

impl ParamTable for NoParams {
    const DOCS: &'static [ParamDoc] = &[];
    fn validate(&self) -> Result<(), String> {
        Ok(())
    }
}

/// Whether changing a key re-bakes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ParamKind {
    /// Part of the bake's cache key.
    Bake,
    /// Used only when drawing.
    Draw,
}

/// One row of `sylvan params`.
#[derive(Debug, Clone, Serialize)]
pub struct ParamSpec {
    /// The key.
    pub key: String,
    /// Bake or draw.
    pub kind: ParamKind,
    /// The default, as TOML would write it.
    pub default: String,
    /// Unit, or empty.
    pub unit: &'static str,
    /// One-line doc.
    pub doc: &'static str,
}

/// The rows of `B` (bake) then `D` (draw), with their defaults.
pub fn schema<B: ParamTable, D: ParamTable>() -> Vec<ParamSpec> {
    let mut out = rows::<B>(ParamKind::Bake);
    out.extend(rows::<D>(ParamKind::Draw));
    out
}

/// The documented keys, then any serialised key without a doc (empty `doc`, which the
/// registry's test refuses); a documented key that is not a field shows `(missing)`.
fn rows<P: ParamTable>(kind: ParamKind) -> Vec<ParamSpec> {
    let defaults = defaults_of::<P>();
    let mut out: Vec<ParamSpec> = P::DOCS
        .iter()
        .map(|d| ParamSpec {
            key: d.key.to_string(),
            kind,
            default: defaults
                .get(d.key)
                .map_or_else(|| "(missing)".to_string(), show_json),
            unit: d.unit,
            doc: d.doc,
        })
        .collect();
    for (k, v) in &defaults {
        if !P::DOCS.iter().any(|d| d.key == k) {
            out.push(ParamSpec {
                key: k.clone(),
                kind,
                default: show_json(v),
                unit: "",
                doc: "",
            });
        }
    }
    out
}

fn defaults_of<P: ParamTable>() -> serde_json::Map<String, serde_json::Value> {
    match serde_json::to_value(P::default()) {
        Ok(serde_json::Value::Object(m)) => m,
        _ => serde_json::Map::new(),
    }
}

/// A JSON value written as TOML would (`null` as "(none)").
fn show_json(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => "(none)".into(),
        serde_json::Value::Array(a) => {
            format!(
                "[{}]",
                a.iter().map(show_json).collect::<Vec<_>>().join(", ")
            )
        }
        // Parameters are `f32`: print the shortest text that reads back as the same `f32`.
        serde_json::Value::Number(n) if n.is_f64() => {
            let f = n.as_f64().unwrap_or_default() as f32;
            if f.fract() == 0.0 {
                format!("{f:.1}")
            } else {
                format!("{f}")
            }
        }
        other => other.to_string(),
    }
}

fn to_json(v: &ParamValue) -> Result<serde_json::Value, String> {
    Ok(match v {
        ParamValue::Bool(b) => (*b).into(),
        ParamValue::Int(i) => (*i).into(),
        ParamValue::Float(f) => serde_json::Number::from_f64(*f)
            .map(serde_json::Value::Number)
            .ok_or_else(|| format!("{f} is not a finite number"))?,
        ParamValue::Str(s) => s.clone().into(),
        ParamValue::Array(a) => a.iter().map(to_json).collect::<Result<Vec<_>, _>>()?.into(),
    })
}

/// Levenshtein distance (for "did you mean").
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The candidate nearest to `word`.
pub fn nearest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .min_by_key(|c| edit_distance(word, c))
}

fn error(s: &Setting, what: String, fix: String) -> RenderError {
    RenderError::Param(format!("{}: {what} — {fix}", s.origin))
}

/// The settings that turn `P`'s defaults into `p` (its non-default fields), for programs that
/// hold typed parameters and hand them to a renderer ([`crate::RenderOptions::settings`]).
pub fn settings_of<P: ParamTable>(technique: &str, p: &P) -> Vec<Setting> {
    let defaults = defaults_of::<P>();
    let Ok(serde_json::Value::Object(values)) = serde_json::to_value(p) else {
        return Vec::new();
    };
    values
        .into_iter()
        .filter(|(k, v)| defaults.get(k) != Some(v))
        .filter_map(|(key, v)| {
            let value = from_json(&v)?;
            Some(Setting {
                technique: technique.to_string(),
                origin: sylvan_scene::Origin::Arg(format!("{technique}.{key}={value}")),
                key,
                value,
            })
        })
        .collect()
}

fn from_json(v: &serde_json::Value) -> Option<ParamValue> {
    Some(match v {
        serde_json::Value::Bool(b) => ParamValue::Bool(*b),
        serde_json::Value::Number(n) => match n.as_i64() {
            Some(i) => ParamValue::Int(i),
            None => ParamValue::Float(n.as_f64()?),
        },
        serde_json::Value::String(s) => ParamValue::Str(s.clone()),
        serde_json::Value::Array(a) => {
            ParamValue::Array(a.iter().map(from_json).collect::<Option<Vec<_>>>()?)
        }
        serde_json::Value::Null | serde_json::Value::Object(_) => return None,
    })
}

/// Applies `settings` (all for technique `name`, in order) over the defaults of `B` and `D`:
/// each key goes to the struct that has it. The first bad setting is the error.
pub fn resolve<B: ParamTable, D: ParamTable>(
    name: &str,
    settings: &[&Setting],
) -> Result<(B, D), RenderError> {
    let mut bake = defaults_of::<B>();
    let mut draw = defaults_of::<D>();
    let (mut b, mut d) = (B::default(), D::default());
    for s in settings {
        let (table, is_bake) = if bake.contains_key(&s.key) {
            (&mut bake, true)
        } else if draw.contains_key(&s.key) {
            (&mut draw, false)
        } else {
            let keys = B::DOCS.iter().chain(D::DOCS).map(|d| d.key);
            let fix = match nearest(&s.key, keys) {
                Some(k) => {
                    format!("did you mean `{name}.{k}`? (`sylvan params {name}` lists every key)")
                }
                None => format!("technique `{name}` has no parameters"),
            };
            return Err(error(s, format!("unknown key `{name}.{}`", s.key), fix));
        };
        let value = to_json(&s.value).map_err(|why| {
            error(
                s,
                format!("{name}.{} = {}: {why}", s.key, s.value),
                "give a finite number".into(),
            )
        })?;
        let default = table.get(&s.key).cloned().unwrap_or_default();
        table.insert(s.key.clone(), value);
        let expected = |e: serde_json::Error| {
            let msg = e.to_string();
            let why = msg.split(" at line").next().unwrap_or(&msg).to_string();
            error(
                s,
                format!("{name}.{} = {}: {why}", s.key, s.value),
                format!("give a value like the default, {}", show_json(&default)),
            )
        };
        let checked = if is_bake {
            let v: B = serde_json::from_value(serde_json::Value::Object(bake.clone()))
                .map_err(expected)?;
            let r = v.validate();
            b = v;
            r
        } else {
            let v: D = serde_json::from_value(serde_json::Value::Object(draw.clone()))
                .map_err(expected)?;
            let r = v.validate();
            d = v;
            r
        };
        checked.map_err(|why| {
            error(
                s,
                format!("{name}.{} = {}: {why}", s.key, s.value),
                format!("see `sylvan params {name}`"),
            )
        })?;
    }
    Ok((b, d))
}

/// A `serde` adapter for direction-set sizes: stored as a subdivision level 0..=3, written as
/// the number of directions (6, 18, 66 or 258).
pub mod direction_count {
    use crate::directions::SAMPLE_COUNTS;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the count of `level`.
    pub fn serialize<S: Serializer>(level: &u32, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(SAMPLE_COUNTS.get(*level as usize).copied().unwrap_or(0) as u64)
    }

    /// Reads a count back into its level.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
        let n = u64::deserialize(d)?;
        SAMPLE_COUNTS
            .iter()
            .position(|&c| c as u64 == n)
            .map(|l| l as u32)
            .ok_or_else(|| {
                serde::de::Error::custom(format!("{n} directions: expected 6, 18, 66 or 258"))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_key() {
        assert_eq!(
            nearest("open_texel_pixel", ["levels", "open_texel_pixels", "band"]),
            Some("open_texel_pixels")
        );
        assert_eq!(edit_distance("abc", "abc"), 0);
        assert_eq!(edit_distance("abc", "abd"), 1);
        assert_eq!(edit_distance("", "ab"), 2);
    }
}
