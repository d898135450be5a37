//! Tree positions from a CSV stand table: a header row naming the columns, `x` and `y` required
//! (terrain X and Z, metres), optionally one size column — `height` (metres, used as is), `dbh`
//! or `size` (scaled into the species' `height_m` range: `size` linearly, `dbh` by the
//! height–diameter allometry h ∝ dbh^0.6). Other columns are ignored. Delimiter `,`, `;` or tab
//! (from the header); fields are quoted per RFC 4180 (via the `csv` crate: `"1,2"` is one
//! field); blank lines and lines starting with `#` are skipped. Errors point at the
//! file, line and column of the bad field.

use crate::error::{ErrorKind, Location, SceneError, read_text};
use crate::placement::MAX_TREES;
use crate::rng::Rng;
use crate::species::MAX_TREE_HEIGHT_M;
use crate::types::{Terrain, TreeInstance};
use glam::Vec3;
use std::path::Path;

/// Most data rows in a positions CSV.
pub const MAX_CSV_ROWS: usize = MAX_TREES;
/// Largest positions CSV, bytes (checked while reading).
pub const MAX_CSV_BYTES: u64 = 256 * 1024 * 1024;

/// The optional size column.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SizeKind {
    Height,
    Dbh,
    Size,
}

/// Byte offsets of the fields of the record starting at byte `start` of `text`, per RFC 4180
/// (a delimiter inside double quotes does not split; `""` is a quote) — for error columns.
fn field_starts(text: &str, start: usize, delim: u8) -> Vec<usize> {
    let bytes = text.as_bytes();
    let mut starts = vec![start];
    let mut quoted = false;
    for (i, &b) in bytes.iter().enumerate().skip(start) {
        match b {
            b'"' => quoted = !quoted,
            b'\n' | b'\r' if !quoted => break,
            b if b == delim && !quoted => starts.push(i + 1),
            _ => {}
        }
    }
    starts
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
    let text = read_text(path, MAX_CSV_BYTES, at, "positions CSV")?;
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
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let err = |offset: usize, what: String, fix: &str| {
        SceneError::new(
            ErrorKind::Csv,
            Location::at_offset(path, text, offset),
            what,
            fix,
        )
    };
    // The delimiter is the first of `,` `;` tab on the header line (the first line that is not
    // blank or a comment).
    let header_line = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .unwrap_or("");
    let delim = [b',', b';', b'\t']
        .into_iter()
        .find(|&d| header_line.as_bytes().contains(&d))
        .unwrap_or(b',');
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
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delim)
        .comment(Some(b'#'))
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut records = reader.records().filter(|r| {
        r.as_ref().map_or(true, |r| {
            !(r.iter().all(str::is_empty) || r.get(0).is_some_and(|f| f.starts_with('#')))
        })
    });
    let csv_err = |e: csv::Error| {
        let offset = e.position().map_or(0, |p| p.byte() as usize);
        err(
            offset,
            format!("malformed CSV: {e}"),
            "quote fields per RFC 4180 (\"a,b\"; a quote inside is written \"\")",
        )
    };
    let Some(header) = records.next().transpose().map_err(csv_err)? else {
        return Err(err(
            0,
            "empty positions CSV".into(),
            "add a header row such as `x,y,height`",
        ));
    };
    let header_at = header.position().map_or(0, |p| p.byte() as usize);
    let names: Vec<String> = header.iter().map(str::to_ascii_lowercase).collect();
    let find = |name: &str| names.iter().position(|n| n == name);
    let (Some(xi), Some(yi)) = (find("x"), find("y")) else {
        let missing = if find("x").is_none() { "x" } else { "y" };
        return Err(err(
            header_at,
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
    let mut rng = Rng::new(seed ^ 0xC5C5_0000 ^ species as u64);
    let mut trees = Vec::with_capacity(rows);
    let mut sizes = Vec::with_capacity(if size_col.is_some() { rows } else { 0 });
    for record in records {
        let record = record.map_err(csv_err)?;
        let row_at = record.position().map_or(0, |p| p.byte() as usize);
        let starts = field_starts(text, row_at, delim);
        let field_at = |i: usize| {
            // Skip the leading blanks that Trim::All removed, to point at the value itself.
            let s = starts.get(i).copied().unwrap_or(row_at);
            s + text[s..].len() - text[s..].trim_start_matches([' ', '\t']).len()
        };
        let end_at = row_at
            + text[row_at..]
                .find(['\n', '\r'])
                .unwrap_or(text.len() - row_at);
        let number = |i: usize, name: &str| -> Result<(f32, usize), SceneError> {
            let Some(f) = record.get(i) else {
                return Err(err(
                    end_at,
                    format!(
                        "the row has {} fields; column `{name}` is missing",
                        record.len()
                    ),
                    "give every row a value for each header column",
                ));
            };
            match f.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok((v, field_at(i))),
                _ => Err(err(
                    field_at(i),
                    format!("`{f}` in column `{name}` is not a number"),
                    "write a plain decimal number in metres",
                )),
            }
        };
        let (x, xat) = number(xi, "x")?;
        let (z, zat) = number(yi, "y")?;
        if !terrain.contains(x, z) {
            let at = if (0.0..=terrain.size[0]).contains(&x) {
                zat
            } else {
                xat
            };
            return Err(err(
                at,
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
            let (v, at) = number(i, &name)?;
            if v <= 0.0 {
                return Err(err(
                    at,
                    format!("{name} {v} is not positive"),
                    "sizes must be greater than 0",
                ));
            }
            if kind == SizeKind::Height && v > MAX_TREE_HEIGHT_M {
                return Err(err(
                    at,
                    format!(
                        "height {} m is taller than the limit of {MAX_TREE_HEIGHT_M} m",
                        crate::error::num(v)
                    ),
                    "give tree heights in metres",
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
            seed: 0,
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
    fn quoted_fields_follow_rfc_4180() {
        let t = parse("note,x,y,height\n\"1,2\",20,15,6\n\"say \"\"hi\"\"\",3,4,5\n").unwrap();
        assert_eq!(t[0].position, Vec3::new(20.0, 3.0, 15.0));
        assert_eq!((t[0].height, t[1].height), (6.0, 5.0));
        let e = parse("note,x,y\n\"a,b\",1,zz\n").unwrap_err().to_string();
        assert!(e.starts_with("stand.csv:2:9: `zz` in column `y`"), "{e}");
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
        let e = parse("x,y,height\n1,2,1e30\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:2:5: height 1e30 m is taller"),
            "{e}"
        );
        let e = parse("x,y,size\n1,2,0\n").unwrap_err().to_string();
        assert!(
            e.starts_with("stand.csv:2:5: size 0 is not positive"),
            "{e}"
        );
    }
}
