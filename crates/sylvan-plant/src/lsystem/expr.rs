//! Arithmetic expressions of parametric L-systems (ABOP §1.10): numbers, parameters, defined
//! constants, `+ - * / ^`, comparisons `< <= > >= == !=`, logic `&& || !`, and the functions
//! `sqrt sin cos tan asin acos atan exp log abs floor ceil round min max pow`. Trigonometric
//! functions take and return degrees (angles are degrees everywhere in `.lsys` files).
//!
//! Expressions are parsed once into a tree whose variables are slot indices; evaluation never
//! panics: division by zero and non-finite results are errors carrying the source position.
//! Parse depth is bounded by [`MAX_EXPR_DEPTH`] so that evaluation cannot overflow the stack.

use super::cursor::Cursor;
use crate::error::Pos;

/// Deepest expression tree accepted (parentheses, operators and calls all count).
pub const MAX_EXPR_DEPTH: u32 = 64;

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^` (power, right-associative)
    Pow,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `&&`
    And,
    /// `||`
    Or,
}

/// A built-in function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Func {
    /// Square root.
    Sqrt,
    /// Sine of degrees.
    Sin,
    /// Cosine of degrees.
    Cos,
    /// Tangent of degrees.
    Tan,
    /// Arc sine, in degrees.
    Asin,
    /// Arc cosine, in degrees.
    Acos,
    /// Arc tangent, in degrees.
    Atan,
    /// e^x.
    Exp,
    /// Natural logarithm.
    Log,
    /// Absolute value.
    Abs,
    /// Round down.
    Floor,
    /// Round up.
    Ceil,
    /// Round to nearest.
    Round,
    /// Smaller of two.
    Min,
    /// Larger of two.
    Max,
    /// `pow(a, b)` = `a ^ b`.
    Pow,
}

impl Func {
    fn from_name(name: &str) -> Option<(Func, usize)> {
        Some(match name {
            "sqrt" => (Func::Sqrt, 1),
            "sin" => (Func::Sin, 1),
            "cos" => (Func::Cos, 1),
            "tan" => (Func::Tan, 1),
            "asin" => (Func::Asin, 1),
            "acos" => (Func::Acos, 1),
            "atan" => (Func::Atan, 1),
            "exp" => (Func::Exp, 1),
            "log" | "ln" => (Func::Log, 1),
            "abs" => (Func::Abs, 1),
            "floor" => (Func::Floor, 1),
            "ceil" => (Func::Ceil, 1),
            "round" => (Func::Round, 1),
            "min" => (Func::Min, 2),
            "max" => (Func::Max, 2),
            "pow" => (Func::Pow, 2),
            _ => return None,
        })
    }
}

/// A parsed expression. Variables are indices into the evaluation environment.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A constant.
    Num(f64),
    /// A parameter slot.
    Var(u16),
    /// `-x`
    Neg(Box<Expr>),
    /// `!x`
    Not(Box<Expr>),
    /// `a op b`, with the operator's position for error messages.
    Bin(BinOp, Box<Expr>, Box<Expr>, Pos),
    /// `f(args)`, with the call's position.
    Call(Func, Vec<Expr>, Pos),
}

/// An evaluation failure: what and where.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalError {
    /// Where the failing operator or call is.
    pub pos: Pos,
    /// What went wrong.
    pub what: String,
}

fn truth(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

impl Expr {
    /// Evaluates with `env` holding the values of the variable slots.
    pub fn eval(&self, env: &[f64]) -> Result<f64, EvalError> {
        let v = match self {
            Expr::Num(v) => *v,
            Expr::Var(i) => env.get(*i as usize).copied().unwrap_or(0.0),
            Expr::Neg(a) => -a.eval(env)?,
            Expr::Not(a) => truth(a.eval(env)? == 0.0),
            Expr::Bin(op, a, b, pos) => {
                let x = a.eval(env)?;
                // Short-circuit logic.
                match op {
                    BinOp::And if x == 0.0 => return Ok(0.0),
                    BinOp::Or if x != 0.0 => return Ok(1.0),
                    _ => {}
                }
                let y = b.eval(env)?;
                let r = match op {
                    BinOp::Add => x + y,
                    BinOp::Sub => x - y,
                    BinOp::Mul => x * y,
                    BinOp::Div => {
                        if y == 0.0 {
                            return Err(EvalError {
                                pos: *pos,
                                what: "division by zero".into(),
                            });
                        }
                        x / y
                    }
                    BinOp::Pow => x.powf(y),
                    BinOp::Lt => truth(x < y),
                    BinOp::Le => truth(x <= y),
                    BinOp::Gt => truth(x > y),
                    BinOp::Ge => truth(x >= y),
                    BinOp::Eq => truth(x == y),
                    BinOp::Ne => truth(x != y),
                    BinOp::And | BinOp::Or => truth(y != 0.0),
                };
                if !r.is_finite() {
                    return Err(EvalError {
                        pos: *pos,
                        what: format!(
                            "{} {} {} is not a finite number",
                            compact(x),
                            op_str(*op),
                            compact(y)
                        ),
                    });
                }
                r
            }
            Expr::Call(f, args, pos) => {
                let a = args
                    .first()
                    .map(|e| e.eval(env))
                    .transpose()?
                    .unwrap_or(0.0);
                let b = args.get(1).map(|e| e.eval(env)).transpose()?.unwrap_or(0.0);
                let r = match f {
                    Func::Sqrt => a.sqrt(),
                    Func::Sin => a.to_radians().sin(),
                    Func::Cos => a.to_radians().cos(),
                    Func::Tan => a.to_radians().tan(),
                    Func::Asin => a.asin().to_degrees(),
                    Func::Acos => a.acos().to_degrees(),
                    Func::Atan => a.atan().to_degrees(),
                    Func::Exp => a.exp(),
                    Func::Log => a.ln(),
                    Func::Abs => a.abs(),
                    Func::Floor => a.floor(),
                    Func::Ceil => a.ceil(),
                    Func::Round => a.round(),
                    Func::Min => a.min(b),
                    Func::Max => a.max(b),
                    Func::Pow => a.powf(b),
                };
                if !r.is_finite() {
                    return Err(EvalError {
                        pos: *pos,
                        what: match f {
                            Func::Min | Func::Max | Func::Pow => format!(
                                "{}({}, {}) is not a finite number",
                                format!("{f:?}").to_lowercase(),
                                compact(a),
                                compact(b)
                            ),
                            _ => format!(
                                "{}({}) is not a finite number",
                                format!("{f:?}").to_lowercase(),
                                compact(a)
                            ),
                        },
                    });
                }
                r
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(EvalError {
                pos: Pos::default(),
                what: "value is not a finite number".into(),
            })
        }
    }

    /// Number of nodes: the cost of one evaluation, for the derivation work budget.
    pub fn cost(&self) -> u64 {
        match self {
            Expr::Num(_) | Expr::Var(_) => 1,
            Expr::Neg(a) | Expr::Not(a) => 1 + a.cost(),
            Expr::Bin(_, a, b, _) => 1 + a.cost() + b.cost(),
            Expr::Call(_, args, _) => 1 + args.iter().map(Expr::cost).sum::<u64>(),
        }
    }

    fn has_vars(&self) -> bool {
        match self {
            Expr::Num(_) => false,
            Expr::Var(_) => true,
            Expr::Neg(a) | Expr::Not(a) => a.has_vars(),
            Expr::Bin(_, a, b, _) => a.has_vars() || b.has_vars(),
            Expr::Call(_, args, _) => args.iter().any(Expr::has_vars),
        }
    }
}

fn op_str(op: BinOp) -> &'static str {
    match op {
        BinOp::Add => "+",
        BinOp::Sub => "-",
        BinOp::Mul => "*",
        BinOp::Div => "/",
        BinOp::Pow => "^",
        BinOp::Lt => "<",
        BinOp::Le => "<=",
        BinOp::Gt => ">",
        BinOp::Ge => ">=",
        BinOp::Eq => "==",
        BinOp::Ne => "!=",
        BinOp::And => "&&",
        BinOp::Or => "||",
    }
}

/// Names visible to an expression: parameter slots and defined constants.
pub struct Scope<'a> {
    /// Parameter names; a name's index is its slot.
    pub params: &'a [String],
    /// Constants from `define:` lines.
    pub consts: &'a [(String, f64)],
}

/// A parse failure: where and what.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// Where.
    pub pos: Pos,
    /// What.
    pub what: String,
    /// How to fix it.
    pub fix: String,
}

pub(crate) fn perr(pos: Pos, what: impl Into<String>, fix: impl Into<String>) -> ParseError {
    ParseError {
        pos,
        what: what.into(),
        fix: fix.into(),
    }
}

/// Parses one expression at the cursor; stops before `,` `)` `->` or the end.
/// Constant sub-expressions are folded, so `1/0` fails here, at parse time.
pub fn parse_expr(c: &mut Cursor, scope: &Scope) -> Result<Expr, ParseError> {
    let start = c.pos();
    let (e, _) = parse_bin(c, scope, 0, 0)?;
    if matches!(e, Expr::Num(v) if !v.is_finite()) {
        return Err(perr(
            start,
            "expression is not a finite number",
            "check the arithmetic",
        ));
    }
    Ok(e)
}

fn prec(op: BinOp) -> u8 {
    match op {
        BinOp::Or => 1,
        BinOp::And => 2,
        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge | BinOp::Eq | BinOp::Ne => 3,
        BinOp::Add | BinOp::Sub => 4,
        BinOp::Mul | BinOp::Div => 5,
        BinOp::Pow => 6,
    }
}

fn peek_op(c: &mut Cursor) -> Option<(BinOp, usize)> {
    c.skip_ws();
    let a = c.peek()?;
    let b = c.peek_at(1);
    Some(match (a, b) {
        ('-', Some('>')) => return None,
        ('+', _) => (BinOp::Add, 1),
        ('-', _) => (BinOp::Sub, 1),
        ('*', _) => (BinOp::Mul, 1),
        ('/', _) => (BinOp::Div, 1),
        ('^', _) => (BinOp::Pow, 1),
        ('<', Some('=')) => (BinOp::Le, 2),
        ('<', _) => (BinOp::Lt, 1),
        ('>', Some('=')) => (BinOp::Ge, 2),
        ('>', _) => (BinOp::Gt, 1),
        ('=', Some('=')) => (BinOp::Eq, 2),
        ('=', _) => (BinOp::Eq, 1),
        ('!', Some('=')) => (BinOp::Ne, 2),
        ('&', Some('&')) => (BinOp::And, 2),
        ('|', Some('|')) => (BinOp::Or, 2),
        _ => return None,
    })
}

fn too_deep(pos: Pos) -> ParseError {
    perr(
        pos,
        format!("expression nested deeper than {MAX_EXPR_DEPTH}"),
        "simplify the expression",
    )
}

/// Precedence climbing; returns the expression and its tree depth.
fn parse_bin(
    c: &mut Cursor,
    s: &Scope,
    min_prec: u8,
    depth: u32,
) -> Result<(Expr, u32), ParseError> {
    if depth > MAX_EXPR_DEPTH {
        return Err(too_deep(c.pos()));
    }
    let (mut lhs, mut d) = parse_unary(c, s, depth)?;
    while let Some((op, len)) = peek_op(c) {
        let p = prec(op);
        if p < min_prec {
            break;
        }
        let pos = c.pos();
        c.advance(len);
        // `^` is right-associative; the rest are left-associative.
        let next = if op == BinOp::Pow { p } else { p + 1 };
        let (rhs, rd) = parse_bin(c, s, next, depth + 1)?;
        d = d.max(rd) + 1;
        if d > MAX_EXPR_DEPTH {
            return Err(too_deep(pos));
        }
        lhs = fold(Expr::Bin(op, Box::new(lhs), Box::new(rhs), pos))?;
    }
    Ok((lhs, d))
}

fn fold(e: Expr) -> Result<Expr, ParseError> {
    if e.has_vars() {
        return Ok(e);
    }
    match e.eval(&[]) {
        Ok(v) => Ok(Expr::Num(v)),
        Err(err) => Err(perr(err.pos, err.what, "change the expression")),
    }
}

fn parse_unary(c: &mut Cursor, s: &Scope, depth: u32) -> Result<(Expr, u32), ParseError> {
    if depth > MAX_EXPR_DEPTH {
        return Err(too_deep(c.pos()));
    }
    c.skip_ws();
    match c.peek() {
        Some('-') if c.peek_at(1) != Some('>') => {
            c.advance(1);
            // Unary minus binds looser than `^`: -2^2 = -4.
            let (e, d) = parse_bin(c, s, prec(BinOp::Pow), depth + 1)?;
            Ok((fold(Expr::Neg(Box::new(e)))?, d + 1))
        }
        Some('+') => {
            c.advance(1);
            parse_unary(c, s, depth + 1)
        }
        Some('!') => {
            c.advance(1);
            let (e, d) = parse_unary(c, s, depth + 1)?;
            Ok((fold(Expr::Not(Box::new(e)))?, d + 1))
        }
        _ => parse_atom(c, s, depth),
    }
}

fn parse_atom(c: &mut Cursor, s: &Scope, depth: u32) -> Result<(Expr, u32), ParseError> {
    c.skip_ws();
    let pos = c.pos();
    match c.peek() {
        Some('(') => {
            c.advance(1);
            let (e, d) = parse_bin(c, s, 0, depth + 1)?;
            c.skip_ws();
            if c.peek() != Some(')') {
                return Err(perr(c.pos(), "expected ')'", "close the parenthesis"));
            }
            c.advance(1);
            Ok((e, d + 1))
        }
        Some(ch) if ch.is_ascii_digit() || ch == '.' => {
            let v = c
                .number()
                .ok_or_else(|| perr(pos, "bad number", "write e.g. 0.5 or 2e-3"))?;
            Ok((Expr::Num(v), 1))
        }
        Some(ch) if ch.is_ascii_alphabetic() || ch == '_' => {
            let name = c.ident();
            c.skip_ws();
            if c.peek() == Some('(') {
                let (f, arity) = Func::from_name(&name).ok_or_else(|| {
                    perr(
                        pos,
                        format!("unknown function '{name}'"),
                        "use sqrt, sin, cos, tan, asin, acos, atan, exp, log, abs, floor, ceil, \
                         round, min, max or pow",
                    )
                })?;
                c.advance(1);
                let mut args = Vec::new();
                let mut d = 1;
                loop {
                    let (a, ad) = parse_bin(c, s, 0, depth + 1)?;
                    d = d.max(ad + 1);
                    args.push(a);
                    c.skip_ws();
                    match c.peek() {
                        Some(',') => c.advance(1),
                        Some(')') => {
                            c.advance(1);
                            break;
                        }
                        _ => return Err(perr(c.pos(), "expected ',' or ')'", "close the call")),
                    }
                }
                if args.len() != arity {
                    return Err(perr(
                        pos,
                        format!("{name} takes {arity} argument(s), got {}", args.len()),
                        "fix the call",
                    ));
                }
                Ok((fold(Expr::Call(f, args, pos))?, d))
            } else if let Some(i) = s.params.iter().position(|p| *p == name) {
                Ok((Expr::Var(i as u16), 1))
            } else if let Some((_, v)) = s.consts.iter().rev().find(|(n, _)| *n == name) {
                Ok((Expr::Num(*v), 1))
            } else if name == "pi" {
                Ok((Expr::Num(std::f64::consts::PI), 1))
            } else {
                Err(perr(
                    pos,
                    format!("unknown name '{name}'"),
                    "use a parameter of the predecessor or a `define:` constant",
                ))
            }
        }
        Some(ch) => Err(perr(
            pos,
            format!("expected a number or a name, found '{ch}'"),
            "fix the expression",
        )),
        None => Err(perr(
            pos,
            "expression ends too early",
            "complete the expression",
        )),
    }
}

/// A number for an error message: plain when short, else in exponent form with at most seven
/// significant digits (`1e260`, not 261 digits; `1.5e-9`, not `0.0000000015`).
pub(crate) fn compact(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-6..1e9).contains(&a) {
        let s = format!("{v:.6e}");
        let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exp}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::compact;

    #[test]
    fn numbers_in_messages_are_compact() {
        assert_eq!(compact(1e260), "1e260");
        assert_eq!(compact(-2.5e300), "-2.5e300");
        assert_eq!(compact(1.5e-9), "1.5e-9");
        assert_eq!(compact(12.25), "12.25");
        assert_eq!(compact(0.0), "0");
        assert_eq!(compact(f64::INFINITY), "inf");
        assert_eq!(compact(9.999_999_999_999_999e259), "1e260");
        assert_eq!(compact(1.234_567_89e10), "1.234568e10");
    }

    /// Issue #19: an overflowing parameter printed all 261 digits of 1e260.
    #[test]
    fn overflow_error_is_one_short_line() {
        let src = "iterations: 3\nangle: 20\naxiom: A(1e200)\nA(x) -> F(1) A(x * 1e60)\n";
        let ls = crate::LSystem::parse(src, "big.lsys").unwrap();
        let e = ls.derive().unwrap_err().to_string();
        assert!(e.starts_with("big.lsys:4:"), "{e}");
        assert!(
            e.contains(": 1e260 * 1e60 is not a finite number — "),
            "{e}"
        );
        assert!(e.len() < 200, "{e}");
    }
}
