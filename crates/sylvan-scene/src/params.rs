//! Technique parameters as data: `[technique.NAME]` tables and `[[lod.band]]` tables in the
//! scene file, `--set NAME.key=value` on the command line. This crate only reads them and
//! remembers where each came from; which keys exist and what values they take is the
//! renderer's registry's business (`sylvan-render`, `sylvan params`), so this crate stays free
//! of any technique.

use crate::error::Location;
use std::fmt;

/// A parameter value as written: TOML's scalar types and arrays.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// `true` / `false`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A floating-point number.
    Float(f64),
    /// A string (also any `--set` value that is not a TOML literal, e.g. `cross`).
    Str(String),
    /// An array of values.
    Array(Vec<ParamValue>),
}

impl ParamValue {
    /// Converts a TOML value; tables and dates are refused with what was found.
    pub(crate) fn from_toml(v: &toml::Value) -> Result<Self, String> {
        Ok(match v {
            toml::Value::Boolean(b) => Self::Bool(*b),
            toml::Value::Integer(i) => Self::Int(*i),
            toml::Value::Float(f) => Self::Float(*f),
            toml::Value::String(s) => Self::Str(s.clone()),
            toml::Value::Array(a) => Self::Array(
                a.iter()
                    .map(Self::from_toml)
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            toml::Value::Table(_) => return Err("a table is not a parameter value".into()),
            toml::Value::Datetime(_) => return Err("a date is not a parameter value".into()),
        })
    }

    /// Parses a `--set` value: a TOML literal (`2`, `0.5`, `true`, `"x"`, `[1, 0, 0]`), else
    /// the text itself as a string (`cross`).
    pub fn parse_arg(text: &str) -> Self {
        #[derive(serde::Deserialize)]
        struct One {
            v: toml::Value,
        }
        match toml::from_str::<One>(&format!("v = {text}")) {
            Ok(one) => Self::from_toml(&one.v).unwrap_or_else(|_| Self::Str(text.to_string())),
            Err(_) => Self::Str(text.to_string()),
        }
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{b}"),
            Self::Int(i) => write!(f, "{i}"),
            Self::Float(x) => write!(f, "{x}"),
            Self::Str(s) => write!(f, "{s:?}"),
            Self::Array(a) => {
                f.write_str("[")?;
                for (i, v) in a.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{v}")?;
                }
                f.write_str("]")
            }
        }
    }
}

/// Where a setting came from, for messages.
#[derive(Debug, Clone, PartialEq)]
pub enum Origin {
    /// A value in a file (`FILE:LINE:COL`).
    File(Location),
    /// A `--set` argument, as given.
    Arg(String),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File(l) => write!(f, "{l}"),
            Self::Arg(a) => write!(f, "--set {a}"),
        }
    }
}

/// One technique parameter: `technique.key = value`, and where it was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    /// The technique's name (`hbt`, …).
    pub technique: String,
    /// The parameter's key (`open_texel_pixels`, …).
    pub key: String,
    /// The value as written.
    pub value: ParamValue,
    /// Where it was written.
    pub origin: Origin,
}

impl Setting {
    /// Parses a `--set TECHNIQUE.KEY=VALUE` argument.
    pub fn from_arg(arg: &str) -> Result<Self, String> {
        let bad = |why: &str| {
            format!(
                "--set {arg}: {why} — write TECHNIQUE.KEY=VALUE, e.g. --set hbt.open_texel_pixels=2 (`sylvan params` lists the keys)"
            )
        };
        let (name, value) = arg.split_once('=').ok_or_else(|| bad("no '='"))?;
        let (technique, key) = name
            .trim()
            .split_once('.')
            .ok_or_else(|| bad("no '.' between the technique and the key"))?;
        if technique.trim().is_empty() || key.trim().is_empty() {
            return Err(bad("the technique or the key is empty"));
        }
        Ok(Self {
            technique: technique.trim().to_string(),
            key: key.trim().to_string(),
            value: ParamValue::parse_arg(value.trim()),
            origin: Origin::Arg(arg.to_string()),
        })
    }
}

/// One band of the LOD chain written as a `[[lod.band]]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct LodBand {
    /// The technique drawing the band.
    pub technique: String,
    /// Start distance (metres).
    pub from: f32,
    /// End distance (metres; `f32::INFINITY` when `to` is absent).
    pub to: f32,
    /// The band's own parameters (its `params` table), over the scene's `[technique.NAME]`.
    pub params: Vec<Setting>,
    /// Where the band's table starts.
    pub origin: Origin,
}
