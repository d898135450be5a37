//! Parser of `.lsys` files: `key: value` header lines, `PRED -> SUCC` productions, `#` comments.
//! Every error names its `FILE:LINE:COL`.

use super::cursor::Cursor;
use super::expr::{Expr, ParseError, Scope, parse_expr, perr};
use super::{
    Blade, DEFAULT_LIMIT, LSystem, LeafKind, MAX_ITERATIONS, MAX_LIMIT, MAX_PARAMS,
    MAX_SOURCE_BYTES, Pattern, Production, SuccModule, TURTLE_SYMBOLS, Word, is_module_symbol,
};
use crate::PlantError;
use crate::error::Pos;

const KEYS: &str = "name, iterations, angle, step, width, taper, leaf, leaves, blade, twig, seed, limit, \
                    tropism, ignore, define, axiom";

fn to_err(file: &str, e: ParseError) -> PlantError {
    PlantError::at(file, e.pos, e.what, e.fix)
}

/// Strips a `#` comment.
fn strip_comment(line: &str) -> &str {
    match line.find('#') {
        Some(i) => &line[..i],
        None => line,
    }
}

fn is_production(line: &str) -> bool {
    line.contains("->") || line.contains('→')
}

pub(super) fn parse(src: &str, file: &str) -> Result<LSystem, PlantError> {
    if src.len() > MAX_SOURCE_BYTES {
        return Err(PlantError::file(
            file,
            format!(
                "source is {} bytes, more than the limit of {MAX_SOURCE_BYTES}",
                src.len()
            ),
            "split or shorten the file",
        ));
    }
    let mut ls = LSystem {
        file: file.to_string(),
        name: None,
        iterations: 0,
        angle: 0.0,
        step: 1.0,
        width: f64::NAN,
        taper: 0.7,
        leaf_size: f64::NAN,
        leaf_kind: LeafKind::Broadleaf,
        blade: LeafKind::Broadleaf.default_blade(),
        twig: 0.0,
        seed: 0,
        limit: DEFAULT_LIMIT,
        tropism: None,
        ignore: Vec::new(),
        axiom: Word::default(),
        productions: Vec::new(),
    };
    let mut consts: Vec<(String, f64)> = Vec::new();
    let mut axiom_src: Option<(String, u32, u32)> = None;
    let mut blade_src: Option<(Blade, Pos)> = None;
    let (mut seen_iter, mut seen_angle) = (false, false);
    let lines: Vec<&str> = src.lines().collect();
    // Pass 1: the header (defines must come before their use, productions may come anywhere).
    for (ln, raw) in lines.iter().enumerate() {
        let line = strip_comment(raw);
        let lno = ln as u32 + 1;
        if line.trim().is_empty() || is_production(line) {
            continue;
        }
        let mut c = Cursor::new(line, lno, 0);
        c.skip_ws();
        let kpos = c.pos();
        let key = c.ident();
        c.skip_ws();
        if key.is_empty() || c.peek() != Some(':') {
            return Err(PlantError::at(
                file,
                kpos,
                "expected `key: value` or a production `PRED -> SUCC`",
                format!("header keys are {KEYS}; productions need `->`"),
            ));
        }
        c.advance(1);
        c.skip_ws();
        let vpos = c.pos();
        let scope = Scope {
            params: &[],
            consts: &consts,
        };
        let num = |c: &mut Cursor| -> Result<f64, PlantError> {
            let v = parse_expr(c, &scope).map_err(|e| to_err(file, e))?;
            let Expr::Num(v) = v else {
                return Err(PlantError::at(
                    file,
                    vpos,
                    "value must be a constant",
                    "use a number",
                ));
            };
            if !c.at_end() {
                return Err(PlantError::at(
                    file,
                    c.pos(),
                    "unexpected text after the value",
                    "remove it",
                ));
            }
            Ok(v)
        };
        let bad = |what: &str, fix: &str| PlantError::at(file, vpos, what, fix);
        match key.as_str() {
            "name" => ls.name = Some(c.rest().trim().to_string()),
            "iterations" => {
                let v = num(&mut c)?;
                if v.fract() != 0.0 || !(0.0..=MAX_ITERATIONS as f64).contains(&v) {
                    return Err(bad(
                        &format!("iterations must be a whole number in 0..={MAX_ITERATIONS}"),
                        "use e.g. `iterations: 5`",
                    ));
                }
                ls.iterations = v as u32;
                seen_iter = true;
            }
            "angle" => {
                ls.angle = num(&mut c)?;
                seen_angle = true;
            }
            "step" | "width" | "leaf" | "taper" => {
                let v = num(&mut c)?;
                if v <= 0.0 || (key == "taper" && v > 1.0) {
                    return Err(bad(
                        &format!("{key} must be positive"),
                        "use a value > 0 (taper ≤ 1)",
                    ));
                }
                match key.as_str() {
                    "step" => ls.step = v,
                    "width" => ls.width = v,
                    "leaf" => ls.leaf_size = v,
                    _ => ls.taper = v,
                }
            }
            "twig" => {
                let v = num(&mut c)?;
                if v.is_nan() || v < 0.0 {
                    return Err(bad(
                        "twig must be zero or positive",
                        "give the thinnest diameter drawn as wood, e.g. `twig: 0.02`",
                    ));
                }
                ls.twig = v;
            }
            "seed" => {
                let v = num(&mut c)?;
                if v < 0.0 || v.fract() != 0.0 || v > 9.0e15 {
                    return Err(bad("seed must be a whole number ≥ 0", "use e.g. `seed: 7`"));
                }
                ls.seed = v as u64;
            }
            "limit" => {
                let v = num(&mut c)?;
                if v < 1.0 || v > MAX_LIMIT as f64 || v.fract() != 0.0 {
                    return Err(bad(
                        &format!("limit must be a whole number in 1..={MAX_LIMIT}"),
                        "declare the longest string the derivation may produce",
                    ));
                }
                ls.limit = v as usize;
            }
            "tropism" => {
                // Space- or comma-separated numbers (so `0 -1 0 0.2` is four values).
                let rest = c.rest();
                let mut vals = Vec::new();
                let mut col = c.pos().col - 1;
                for piece in rest.split([' ', '\t', ',']) {
                    if !piece.is_empty() {
                        let mut pc = Cursor::new(piece, lno, col);
                        let e = parse_expr(&mut pc, &scope).map_err(|e| to_err(file, e))?;
                        let (Expr::Num(v), true) = (e, pc.at_end()) else {
                            return Err(PlantError::at(
                                file,
                                pc.pos(),
                                "tropism values must be numbers",
                                "e.g. `tropism: 0 -1 0 0.2`",
                            ));
                        };
                        vals.push(v);
                    }
                    col += piece.chars().count() as u32 + 1;
                }
                if vals.len() != 4 {
                    return Err(bad(
                        "tropism needs 4 numbers: x y z e",
                        "e.g. `tropism: 0 -1 0 0.2`",
                    ));
                }
                ls.tropism = Some(([vals[0], vals[1], vals[2]], vals[3]));
            }
            "leaves" => {
                ls.leaf_kind = match c.rest().trim() {
                    "broadleaf" => LeafKind::Broadleaf,
                    "needles" => LeafKind::Needles,
                    "chestnut" => LeafKind::Chestnut,
                    "beech" => LeafKind::Beech,
                    _ => {
                        return Err(bad(
                            "unknown leaf kind",
                            "use `leaves: broadleaf`, `needles`, `chestnut` or `beech`",
                        ));
                    }
                }
            }
            "blade" => {
                // `blade: ROWS FOLD CURL`, space-separated constants.
                let fix = "e.g. `blade: 2 20 30` (rows 1 or 2, fold 0–80°, curl −90–90°)";
                let mut vals = Vec::new();
                let mut col = c.pos().col - 1;
                for piece in c.rest().split([' ', '\t']) {
                    if !piece.is_empty() {
                        let mut pc = Cursor::new(piece, lno, col);
                        let e = parse_expr(&mut pc, &scope).map_err(|e| to_err(file, e))?;
                        let (Expr::Num(v), true) = (e, pc.at_end()) else {
                            return Err(PlantError::at(
                                file,
                                Pos {
                                    line: lno,
                                    col: col + 1,
                                },
                                "blade values must be numbers",
                                fix,
                            ));
                        };
                        vals.push((v, col + 1));
                    }
                    col += piece.chars().count() as u32 + 1;
                }
                let at = |i: usize, what: &str| {
                    PlantError::at(
                        file,
                        Pos {
                            line: lno,
                            col: vals.get(i).map_or(vpos.col, |v| v.1),
                        },
                        what,
                        fix,
                    )
                };
                if vals.len() != 3 {
                    return Err(at(3, "blade needs 3 numbers: rows fold curl"));
                }
                let (rows, fold, curl) = (vals[0].0, vals[1].0, vals[2].0);
                if !(rows == 1.0 || rows == 2.0) {
                    return Err(at(0, "blade rows must be 1 or 2 (4 or 8 triangles)"));
                }
                if !(0.0..=80.0).contains(&fold) {
                    return Err(at(1, "blade fold must be 0–80 degrees"));
                }
                if !(-90.0..=90.0).contains(&curl) {
                    return Err(at(2, "blade curl must be −90–90 degrees"));
                }
                let blade = Blade {
                    rows: rows as u32,
                    fold,
                    curl,
                };
                blade_src = Some((blade, vpos));
            }
            "ignore" => {
                while !c.at_end() {
                    let p = c.pos();
                    let ch = c.peek().unwrap_or(' ');
                    if !is_module_symbol(ch) || ch == '[' || ch == ']' {
                        return Err(PlantError::at(
                            file,
                            p,
                            format!("cannot ignore '{ch}'"),
                            "list module symbols, e.g. `ignore: + - F`",
                        ));
                    }
                    ls.ignore.push(ch as u8);
                    c.advance(1);
                }
            }
            "define" => {
                let name = c.ident();
                c.skip_ws();
                if name.is_empty()
                    || !name.starts_with(|ch: char| ch.is_ascii_alphabetic() || ch == '_')
                    || c.peek() != Some('=')
                {
                    return Err(bad(
                        "expected `define: NAME = VALUE`",
                        "e.g. `define: r1 = 0.9`",
                    ));
                }
                c.advance(1);
                let v = num(&mut c)?;
                consts.push((name, v));
            }
            "axiom" => axiom_src = Some((line.to_string(), lno, c.pos().col - 1)),
            _ => {
                return Err(PlantError::at(
                    file,
                    kpos,
                    format!("unknown header key '{key}'"),
                    format!("use one of: {KEYS}"),
                ));
            }
        }
    }
    let Some((axiom_line, alno, acol)) = axiom_src else {
        return Err(PlantError::at(
            file,
            Pos { line: 1, col: 1 },
            "missing axiom",
            "add a line `axiom: F` (the initial string)",
        ));
    };
    if !seen_iter {
        return Err(PlantError::at(
            file,
            Pos { line: 1, col: 1 },
            "missing `iterations:`",
            "add e.g. `iterations: 5`",
        ));
    }
    if !seen_angle {
        return Err(PlantError::at(
            file,
            Pos { line: 1, col: 1 },
            "missing `angle:`",
            "add e.g. `angle: 25.7` (degrees)",
        ));
    }
    ls.blade = match blade_src {
        Some((_, pos)) if !ls.leaf_kind.is_single_leaf() => {
            return Err(PlantError::at(
                file,
                pos,
                "`blade:` shapes single leaves, but these leaves are cards",
                "add `leaves: chestnut` or `leaves: beech`, or remove the `blade:` line",
            ));
        }
        Some((b, _)) => b,
        None => ls.leaf_kind.default_blade(),
    };
    if ls.width.is_nan() {
        ls.width = ls.step / 10.0;
    }
    if ls.leaf_size.is_nan() {
        ls.leaf_size = ls.step / 2.0;
    }
    // The axiom: a successor with no parameters in scope.
    let mut c = Cursor::new(&axiom_line[..], alno, 0);
    c.advance(acol as usize);
    let scope = Scope {
        params: &[],
        consts: &consts,
    };
    let succ = parse_successor(&mut c, &scope).map_err(|e| to_err(file, e))?;
    if succ.is_empty() {
        return Err(PlantError::at(
            file,
            c.pos(),
            "empty axiom",
            "write the initial string, e.g. `axiom: F`",
        ));
    }
    for m in &succ {
        let args: Vec<f64> = m
            .args
            .iter()
            .map(|a| if let Expr::Num(v) = a { *v } else { 0.0 })
            .collect();
        ls.axiom.push(m.sym, &args);
    }
    // Pass 2: productions.
    for (ln, raw) in lines.iter().enumerate() {
        let line = strip_comment(raw);
        if !is_production(line) {
            continue;
        }
        let mut c = Cursor::new(line, ln as u32 + 1, 0);
        let p = parse_production(&mut c, &consts).map_err(|e| to_err(file, e))?;
        ls.productions.push(p);
    }
    Ok(ls)
}

/// A pattern list: `A(x,y)B C(z)` up to a character that is not a module symbol.
fn parse_patterns(c: &mut Cursor, names: &mut Vec<String>) -> Result<Vec<Pattern>, ParseError> {
    let mut out = Vec::new();
    loop {
        c.skip_ws();
        let pos = c.pos();
        let Some(ch) = c.peek() else { break };
        if ch == '[' || ch == ']' {
            return Err(perr(
                pos,
                "brackets in a predecessor or context are not supported",
                "remove them (contexts skip branches automatically)",
            ));
        }
        if !is_module_symbol(ch) || (ch == '-' && c.peek_at(1) == Some('>')) {
            break;
        }
        c.advance(1);
        let mut n = 0;
        c.skip_ws();
        if c.peek() == Some('(') {
            c.advance(1);
            loop {
                c.skip_ws();
                let npos = c.pos();
                let name = c.ident();
                if name.is_empty() || name.starts_with(|d: char| d.is_ascii_digit()) {
                    return Err(perr(
                        npos,
                        "expected a parameter name",
                        "write formal parameters as names, e.g. A(l,w)",
                    ));
                }
                names.push(name);
                n += 1;
                c.skip_ws();
                match c.peek() {
                    Some(',') => c.advance(1),
                    Some(')') => {
                        c.advance(1);
                        break;
                    }
                    _ => {
                        return Err(perr(
                            c.pos(),
                            "expected ',' or ')'",
                            "close the parameter list",
                        ));
                    }
                }
            }
            if n > MAX_PARAMS {
                return Err(perr(
                    pos,
                    format!("more than {MAX_PARAMS} parameters"),
                    "use fewer parameters",
                ));
            }
        }
        out.push(Pattern { sym: ch as u8, n });
    }
    Ok(out)
}

fn parse_production(c: &mut Cursor, consts: &[(String, f64)]) -> Result<Production, ParseError> {
    c.skip_ws();
    let start = c.pos();
    let mut names = Vec::new();
    let mut first = parse_patterns(c, &mut names)?;
    let first_names = std::mem::take(&mut names);
    c.skip_ws();
    let mut pred_names = Vec::new();
    let (left, left_names, mut pred_list) = if c.peek() == Some('<') {
        c.advance(1);
        let p = parse_patterns(c, &mut pred_names)?;
        (std::mem::take(&mut first), first_names, p)
    } else {
        pred_names = first_names;
        (Vec::new(), Vec::new(), std::mem::take(&mut first))
    };
    c.skip_ws();
    let mut right = Vec::new();
    let mut right_names = Vec::new();
    if c.peek() == Some('>') {
        c.advance(1);
        right = parse_patterns(c, &mut right_names)?;
        if right.is_empty() {
            return Err(perr(
                c.pos(),
                "empty right context",
                "write a module after '>'",
            ));
        }
    }
    if pred_list.len() != 1 {
        return Err(perr(
            start,
            format!("a predecessor is one module, found {}", pred_list.len()),
            "write e.g. `A -> B` or `A < B > C -> D`",
        ));
    }
    let pred = pred_list.remove(0);
    // Slots: predecessor, left context, right context.
    let mut params = pred_names;
    params.extend(left_names);
    params.extend(right_names);
    let scope = Scope {
        params: &params,
        consts,
    };
    c.skip_ws();
    let mut cond = None;
    if c.peek() == Some(':') {
        c.advance(1);
        let e = parse_expr(c, &scope)?;
        cond = Some(e);
    }
    c.skip_ws();
    let apos = c.pos();
    match (c.peek(), c.peek_at(1)) {
        (Some('-'), Some('>')) => c.advance(2),
        (Some('→'), _) => c.advance(1),
        (Some(ch), _) => {
            return Err(perr(
                apos,
                format!("unexpected '{ch}' in the predecessor"),
                "write `PRED -> SUCC`; modules are letters, digits or turtle symbols",
            ));
        }
        (None, _) => return Err(perr(apos, "expected '->'", "write `PRED -> SUCC`")),
    }
    let mut weight = None;
    c.skip_ws();
    if c.peek() == Some('(') {
        c.advance(1);
        let wpos = c.pos();
        let e = parse_expr(
            c,
            &Scope {
                params: &[],
                consts,
            },
        )?;
        let Expr::Num(w) = e else {
            return Err(perr(wpos, "weight must be a constant", "use e.g. ->(0.33)"));
        };
        if w.is_nan() || w < 0.0 {
            return Err(perr(wpos, "weight must be ≥ 0", "use e.g. ->(0.33)"));
        }
        c.skip_ws();
        if c.peek() != Some(')') {
            return Err(perr(
                c.pos(),
                "expected ')' after the weight",
                "write ->(0.33)",
            ));
        }
        c.advance(1);
        weight = Some(w);
    }
    let succ = parse_successor(c, &scope)?;
    let cost = 1
        + cond.as_ref().map_or(0, Expr::cost)
        + succ
            .iter()
            .map(|m| 1 + m.args.iter().map(Expr::cost).sum::<u64>())
            .sum::<u64>();
    Ok(Production {
        pos: start,
        left,
        pred,
        right,
        cond,
        weight,
        succ,
        cost,
    })
}

/// A successor (or axiom): modules with optional argument lists; brackets must balance.
fn parse_successor(c: &mut Cursor, scope: &Scope) -> Result<Vec<SuccModule>, ParseError> {
    let mut out = Vec::new();
    let mut open: Vec<crate::error::Pos> = Vec::new();
    loop {
        c.skip_ws();
        let pos = c.pos();
        let Some(ch) = c.peek() else { break };
        if !is_module_symbol(ch) {
            return Err(perr(
                pos,
                format!("unknown symbol '{ch}'"),
                format!("modules are ASCII letters or digits; turtle symbols are {TURTLE_SYMBOLS}"),
            ));
        }
        c.advance(1);
        match ch {
            '[' => open.push(pos),
            ']' if open.pop().is_none() => {
                return Err(perr(
                    pos,
                    "unbalanced ']'",
                    "remove it or add a matching '['",
                ));
            }
            _ => {}
        }
        let mut args = Vec::new();
        c.skip_ws();
        if c.peek() == Some('(') {
            c.advance(1);
            loop {
                args.push(parse_expr(c, scope)?);
                c.skip_ws();
                match c.peek() {
                    Some(',') => c.advance(1),
                    Some(')') => {
                        c.advance(1);
                        break;
                    }
                    _ => {
                        return Err(perr(
                            c.pos(),
                            "expected ',' or ')'",
                            "close the argument list",
                        ));
                    }
                }
            }
            if args.len() > MAX_PARAMS {
                return Err(perr(
                    pos,
                    format!("more than {MAX_PARAMS} parameters"),
                    "use fewer parameters",
                ));
            }
        }
        out.push(SuccModule {
            sym: ch as u8,
            args,
        });
    }
    if let Some(p) = open.pop() {
        return Err(perr(p, "unbalanced '['", "add the matching ']'"));
    }
    Ok(out)
}
