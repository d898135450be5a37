//! Tree positions from a CSV stand table: a header row naming the columns, `x` and `y` required
//! (terrain X and Z, metres), optionally one size column — `height` (metres, used as is), `dbh`
//! or `size` (scaled into the species' `height_m` range: `size` linearly, `dbh` by the
//! height–diameter allometry h ∝ dbh^0.6). Other columns are ignored. Delimiter `,`, `;` or tab
//! (from the header); blank lines and lines starting with `#` are skipped. Errors point at the
//! file, line and column of the bad field.

use crate::error::{ErrorKind, Location, SceneError};
use crate::placement::MAX_TREES;
use crate::rng::Rng;
use crate::types::{Terrain, TreeInstance};
use glam::Vec3;
use std::path::Path;

/// Most data rows in a positions CSV.
pub const MAX_CSV_ROWS: usize = MAX_TREES;
/// Largest positions CSV, bytes (checked before reading).
pub const MAX_CSV_BYTES: u64 = 256 * 1024 * 1024;

/// The optional size column.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SizeKind {
    Height,
    Dbh,
    Size,
}

/// One field of a line: its text and 1-based character column.
struct Field<'a> {
    text: &'a str,
    col: usize,
}

fn split<'a>(line: &'a str, delim: char) -> Vec<Field<'a>> {
    let mut fields = Vec::new();
    let mut start = 0;
    for piece in line.split(delim) {
        let lead = piece.len() - piece.trim_start().len();
        let col = line[..start + lead].chars().count() + 1;
        let text = piece.trim().trim_matches('"').trim();
        fields.push(Field { text, col });
        start += piece.len() + delim.len_utf8();
    }
    fields
}

/// Read `path` and place one tree of `species` per row on `terrain`. `at` is where the scene
/// names the file (for I/O and limit errors); `seed` drives heights (without a size column) and
/// rotations.
pub(crate) fn read_positions(
    path: &Path,
    at: &Location,
    terrain: &Terrain,
    species: u32,
    height_m: [f32; 2],
    seed: u64,
) -> Result<Vec<TreeInstance>, SceneError> {
    let io_err = |e: std::io::Error| {
        SceneError::new(
            ErrorKind::Io,
            at.clone(),
            format!("cannot read positions CSV {} ({e})", path.display()),
            "check the path (relative paths resolve against the scene file's folder)",
        )
    };
    let len = std::fs::metadata(path).map_err(io_err)?.len();
    if len > MAX_CSV_BYTES {
        return Err(SceneError::new(
            ErrorKind::Limit,
            at.clone(),
            format!(
                "{} is {len} bytes, more than the limit of {MAX_CSV_BYTES}",
                path.display()
            ),
            "split the stand into several species entries or thin it",
        ));
    }
    let text = std::fs::read_to_string(path).map_err(io_err)?;
    parse_positions(&text, path, at, terrain, species, height_m, seed)
}

/// Parse CSV `text` (from `path`, for messages); see [`read_positions`].
pub(crate) fn parse_positions(
    text: &str,
    path: &Path,
    at: &Location,
    terrain: &Terrain,
    species: u32,
    height_m: [f32; 2],
    seed: u64,
) -> Result<Vec<TreeInstance>, SceneError> {
    let err = |line: usize, col: usize, what: String, fix: &str| {
        SceneError::new(ErrorKind::Csv, Location::at(path, line, col), what, fix)
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_start_matches('\u{feff}')))
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(err(
            1,
            1,
            "empty positions CSV".into(),
            "add a header row such as `x,y,height`",
        ));
    };
    let delim = [',', ';', '\t']
        .into_iter()
        .find(|&d| header.contains(d))
        .unwrap_or(',');
    let names: Vec<String> = split(header, delim)
        .iter()
        .map(|f| f.text.to_ascii_lowercase())
        .collect();
    let find = |name: &str| names.iter().position(|n| n == name);
    let (Some(xi), Some(yi)) = (find("x"), find("y")) else {
        let missing = if find("x").is_none() { "x" } else { "y" };
        return Err(err(
            header_line,
            1,
            format!("the header has no `{missing}` column"),
            "name the columns in the first row, e.g. `x,y,height` (x and y are terrain X and Z)",
        ));
    };
    let size_col = [
        ("height", SizeKind::Height),
        ("dbh", SizeKind::Dbh),
        ("size", SizeKind::Size),
    ]
    .into_iter()
    .find_map(|(n, k)| find(n).map(|i| (i, k)));
    let rows = text.lines().count().saturating_sub(1);
    if rows > MAX_CSV_ROWS {
        return Err(SceneError::new(
            ErrorKind::Limit,
            at.clone(),
            format!(
                "{} has {rows} rows, more than the limit of {MAX_CSV_ROWS}",
                path.display()
            ),
            "thin the stand",
        ));
    }
    let mut rng = Rng::new(seed ^ 0xC5C5_0000 ^ species as u64);
    let mut trees = Vec::with_capacity(rows);
    let mut sizes = Vec::with_capacity(if size_col.is_some() { rows } else { 0 });
    for (line_no, line) in lines {
        let fields = split(line, delim);
        let end_col = line.chars().count() + 1;
        let number = |i: usize, name: &str| -> Result<(f32, usize), SceneError> {
            let Some(f) = fields.get(i) else {
                return Err(err(
                    line_no,
                    end_col,
                    format!(
                        "the row has {} fields; column `{name}` is missing",
                        fields.len()
                    ),
                    "give every row a value for each header column",
                ));
            };
            match f.text.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok((v, f.col)),
                _ => Err(err(
                    line_no,
                    f.col,
                    format!("`{}` in column `{name}` is not a number", f.text),
                    "write a plain decimal number in metres",
                )),
            }
        };
        let (x, xcol) = number(xi, "x")?;
        let (z, zcol) = number(yi, "y")?;
        if !terrain.contains(x, z) {
            let col = if (0.0..=terrain.size[0]).contains(&x) {
                zcol
            } else {
                xcol
            };
            return Err(err(
                line_no,
                col,
                format!(
                    "position ({x}, {z}) is outside the terrain [0, {}] × [0, {}]",
                    terrain.size[0], terrain.size[1]
                ),
                "positions are metres from the terrain's corner (x → X, y → Z); fix the row or the \
                 terrain's size_m",
            ));
        }
        if let Some((i, kind)) = size_col {
            let name = names[i].clone();
            let (v, col) = number(i, &name)?;
            if v <= 0.0 {
                return Err(err(
                    line_no,
                    col,
                    format!("{name} {v} is not positive"),
                    "sizes must be greater than 0",
                ));
            }
            sizes.push(match kind {
                SizeKind::Dbh => v.powf(0.6),
                _ => v,
            });
        }
        let height = height_m[0] + (height_m[1] - height_m[0]) * rng.f32();
        trees.push(TreeInstance {
            position: Vec3::new(x, terrain.height_at(x, z), z),
            height,
            rotation: rng.f32() * std::f32::consts::TAU,
            species,
        });
    }
    if let Some((_, kind)) = size_col {
        if kind == SizeKind::Height {
            trees
                .iter_mut()
                .zip(&sizes)
                .for_each(|(t, &h)| t.height = h);
        } else {
            let (lo, hi) = sizes
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            for (t, &s) in trees.iter_mut().zip(&sizes) {
                let f = if hi > lo { (s - lo) / (hi - lo) } else { 0.5 };
                t.height = height_m[0] + (height_m[1] - height_m[0]) * f;
            }
        }
    }
    Ok(trees)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<TreeInstance>, SceneError> {
        let t = Terrain::flat([100.0, 50.0], 3.0);
        let p = Path::new("stand.csv");
        parse_positions(
            text,
            p,
            &Location::file(Path::new("s.toml")),
            &t,
            2,
            [10.0, 20.0],
            1,
        )
    }

    #[test]
    fn positions_and_heights_are_honoured() {
        let trees = parse("id;x;y;height\n1;10;20;7.5\n\n# note\n2; 99.5 ;0;12\n").unwrap();
        assert_eq!(trees.len(), 2);
        assert_eq!(trees[0].position, Vec3::new(10.0, 3.0, 20.0));
        assert_eq!((trees[0].height, trees[1].height), (7.5, 12.0));
        assert_eq!(trees[1].species, 2);
        let scaled = parse("x,y,dbh\n1,1,10\n2,2,40\n3,3,20\n").unwrap();
        assert_eq!((scaled[0].height, scaled[1].height), (10.0, 20.0));
        assert!(scaled[2].height > 10.0 && scaled[2].height < 20.0);
        let plain = parse("x,y\n1,1\n").unwrap();
        assert!((10.0..=20.0).contains(&plain[0].height));
    }

    #[test]
    fn bad_rows_point_at_the_field() {
        let e = parse("x,y\n1,2\n3, abc\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:3:4: `abc` in column `y` is not a number"),
            "{e}"
        );
        let e = parse("x,y\n1,2\n3\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:3:2: the row has 1 fields; column `y` is missing"),
            "{e}"
        );
        let e = parse("x,y\n1,2\n101,2\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:3:1: position (101, 2) is outside"),
            "{e}"
        );
        let e = parse("x,y\n1,-2\n").unwrap_err().to_string();
        assert!(e.starts_with("stand.csv:2:3: position"), "{e}");
        let e = parse("a,b\n1,2\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:1:1: the header has no `x` column"),
            "{e}"
        );
        let e = parse("x,y,size\n1,2,0\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:2:5: size 0 is not positive"),
            "{e}"
        );
    }
}
