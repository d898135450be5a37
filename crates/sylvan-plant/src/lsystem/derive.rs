//! Parallel rewriting (ABOP §1.2): every module is replaced at once by the successor of the
//! first production that matches it (symbol, parameter count, contexts, condition); when the
//! matching productions carry weights `->(w)` one is drawn with probability proportional to its
//! weight (ABOP §1.7), from a generator seeded by `seed:`, in string order, so the same seed
//! gives the same plant. Modules without a matching production are copied (identity).
//!
//! The derived string may not exceed the declared `limit:`; the check runs before each
//! successor is appended, so memory stays bounded; [`MAX_WORK`] bounds time.

use super::{LSystem, MAX_ITERATIONS, MAX_WORK, Pattern, Production, Word};
use crate::PlantError;
use crate::rng::Rng;

pub(super) fn derive(ls: &LSystem, n: u32) -> Result<Word, PlantError> {
    if n > MAX_ITERATIONS {
        return Err(PlantError::file(
            &ls.file,
            format!("{n} iterations requested, more than {MAX_ITERATIONS}"),
            "use fewer iterations",
        ));
    }
    let mut by_sym: Vec<Vec<usize>> = vec![Vec::new(); 256];
    for (i, p) in ls.productions.iter().enumerate() {
        by_sym[p.pred.sym as usize].push(i);
    }
    let mut ignore = [false; 256];
    for &s in &ls.ignore {
        ignore[s as usize] = true;
    }
    let has_context = ls
        .productions
        .iter()
        .any(|p| !p.left.is_empty() || !p.right.is_empty());
    let mut rng = Rng::new(ls.seed);
    let mut work: u64 = 0;
    let mut cur = ls.axiom.clone();
    if cur.len() > ls.limit {
        return Err(limit_error(ls, 0, None));
    }
    let mut env: Vec<f64> = Vec::new();
    let mut picks: Vec<(usize, usize, usize)> = Vec::new(); // (production, env start, env len)
    let mut pick_env: Vec<f64> = Vec::new();
    for it in 0..n {
        if ls.productions.is_empty() {
            break;
        }
        let partners = if has_context {
            cur.bracket_partners()
        } else {
            Vec::new()
        };
        let mut out = Word {
            modules: Vec::with_capacity(cur.len().min(ls.limit)),
            params: Vec::with_capacity(cur.params.len().min(ls.limit)),
        };
        for i in 0..cur.len() {
            work += 1;
            let m = cur.modules[i];
            let cands = &by_sym[m.sym as usize];
            let mut chosen: Option<usize> = None;
            picks.clear();
            pick_env.clear();
            for &pi in cands {
                let p = &ls.productions[pi];
                if p.pred.n != m.n as usize {
                    continue;
                }
                env.clear();
                env.extend_from_slice(cur.args(i));
                if !p.left.is_empty() && !match_left(&cur, i, &p.left, &ignore, &partners, &mut env)
                {
                    continue;
                }
                if !p.right.is_empty()
                    && !match_right(&cur, i, &p.right, &ignore, &partners, &mut env)
                {
                    continue;
                }
                if let Some(c) = &p.cond {
                    work += p.cost;
                    let v = c.eval(&env).map_err(|e| eval_error(ls, p, e))?;
                    if v == 0.0 {
                        continue;
                    }
                }
                match p.weight {
                    None if picks.is_empty() => {
                        chosen = Some(pi);
                        break;
                    }
                    None => {}
                    Some(_) => {
                        picks.push((pi, pick_env.len(), env.len()));
                        pick_env.extend_from_slice(&env);
                    }
                }
            }
            if chosen.is_none() && !picks.is_empty() {
                let total: f64 = picks
                    .iter()
                    .map(|&(pi, _, _)| ls.productions[pi].weight.unwrap_or(0.0))
                    .sum();
                let mut r = rng.next_f64() * total;
                let mut k = picks.len() - 1;
                for (j, &(pi, _, _)) in picks.iter().enumerate() {
                    let w = ls.productions[pi].weight.unwrap_or(0.0);
                    if r < w {
                        k = j;
                        break;
                    }
                    r -= w;
                }
                let (pi, s, l) = picks[k];
                env.clear();
                env.extend_from_slice(&pick_env[s..s + l]);
                chosen = Some(pi);
            }
            match chosen {
                None => {
                    if out.len() + 1 > ls.limit {
                        return Err(limit_error(ls, it + 1, None));
                    }
                    out.push(m.sym, cur.args(i));
                }
                Some(pi) => {
                    let p = &ls.productions[pi];
                    if out.len() + p.succ.len() > ls.limit {
                        return Err(limit_error(ls, it + 1, Some(p)));
                    }
                    work += p.cost;
                    let mut args = [0.0f64; super::MAX_PARAMS];
                    for sm in &p.succ {
                        let na = sm.args.len().min(args.len());
                        for (k, a) in sm.args.iter().take(na).enumerate() {
                            args[k] = a.eval(&env).map_err(|e| eval_error(ls, p, e))?;
                        }
                        out.push(sm.sym, &args[..na]);
                    }
                }
            }
            if work > MAX_WORK {
                return Err(PlantError::file(
                    &ls.file,
                    format!(
                        "derivation needs more than {MAX_WORK} steps (at iteration {})",
                        it + 1
                    ),
                    "lower `iterations:` or simplify the productions",
                ));
            }
        }
        cur = out;
    }
    Ok(cur)
}

fn eval_error(ls: &LSystem, p: &Production, e: super::expr::EvalError) -> PlantError {
    let pos = if e.pos.line == 0 { p.pos } else { e.pos };
    PlantError::at(
        &ls.file,
        pos,
        e.what,
        "guard the production with a condition or change the expression",
    )
}

fn limit_error(ls: &LSystem, it: u32, p: Option<&Production>) -> PlantError {
    let what = format!(
        "derivation exceeds the declared limit of {} modules at iteration {it} of {}",
        ls.limit, ls.iterations
    );
    let fix = format!(
        "lower `iterations:` or raise `limit:` (at most {})",
        super::MAX_LIMIT
    );
    match p {
        Some(p) => PlantError::at(&ls.file, p.pos, what, fix),
        None => PlantError::file(&ls.file, what, fix),
    }
}

/// Left context: walk left, skipping ignored symbols and sibling branches, stepping out of the
/// current branch at `[`.
fn match_left(
    w: &Word,
    i: usize,
    pats: &[Pattern],
    ignore: &[bool; 256],
    partners: &[u32],
    env: &mut Vec<f64>,
) -> bool {
    let mut j = i as isize - 1;
    let mut found = [0usize; 16];
    if pats.len() > found.len() {
        return false;
    }
    for (k, pat) in pats.iter().rev().enumerate() {
        loop {
            if j < 0 {
                return false;
            }
            let s = w.sym(j as usize);
            if s == b']' {
                j = partners[j as usize] as isize - 1;
            } else if s == b'[' || ignore[s as usize] {
                j -= 1;
            } else {
                break;
            }
        }
        let ju = j as usize;
        if w.sym(ju) != pat.sym || w.modules[ju].n as usize != pat.n {
            return false;
        }
        found[k] = ju;
        j -= 1;
    }
    for k in (0..pats.len()).rev() {
        env.extend_from_slice(w.args(found[k]));
    }
    true
}

/// Right context: walk right, skipping ignored symbols and whole branches; fail at the end of
/// the current branch.
fn match_right(
    w: &Word,
    i: usize,
    pats: &[Pattern],
    ignore: &[bool; 256],
    partners: &[u32],
    env: &mut Vec<f64>,
) -> bool {
    let mut j = i + 1;
    for pat in pats {
        loop {
            if j >= w.len() {
                return false;
            }
            let s = w.sym(j);
            if s == b'[' {
                j = partners[j] as usize + 1;
            } else if s == b']' {
                return false;
            } else if ignore[s as usize] {
                j += 1;
            } else {
                break;
            }
        }
        if w.sym(j) != pat.sym || w.modules[j].n as usize != pat.n {
            return false;
        }
        env.extend_from_slice(w.args(j));
        j += 1;
    }
    true
}
