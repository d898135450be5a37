//! The L-system language of `.lsys` files (documented in `docs/lsystem.md`) after ABOP ch. 1
//! (Prusinkiewicz & Lindenmayer, *The Algorithmic Beauty of Plants*, 1990): bracketed OL-systems
//! (§1.6), stochastic (§1.7), context-sensitive with an ignore list (§1.8) and parametric
//! productions with conditions (§1.10).
//!
//! `LSystem::parse` → [`LSystem::derive`] → [`Word`] → `LSystem::interpret` (see `turtle`).
//!
//! Limits, all declared as consts and checked before the memory is taken:
//! [`MAX_SOURCE_BYTES`], [`MAX_ITERATIONS`], [`MAX_LIMIT`] (modules in a derived string; a file
//! may declare a lower `limit:`), [`MAX_PARAMS`] per module, [`MAX_WORK`] derivation steps
//! (bounds time), [`expr::MAX_EXPR_DEPTH`].
//!
//! Deviations from ABOP: context patterns may not contain brackets; a right context skips
//! whole branches (`[...]`) and fails at the end of its own branch, a left context skips
//! sibling branches and steps out of its own (as in cpfg); trigonometric functions use degrees;
//! `%` (cut) is applied by the turtle rather than during derivation (same geometry).

pub mod cursor;
mod derive;
pub mod expr;
mod parse;

use crate::error::Pos;
use expr::Expr;

/// Largest `.lsys` source accepted, bytes.
pub const MAX_SOURCE_BYTES: usize = 1 << 20;
/// Most derivation steps (`iterations:`) accepted.
pub const MAX_ITERATIONS: u32 = 100;
/// Default bound on the length (modules) of a derived string when a file declares no `limit:`.
pub const DEFAULT_LIMIT: usize = 1_000_000;
/// Largest `limit:` a file may declare (modules in a derived string).
pub const MAX_LIMIT: usize = 4_000_000;
/// Most parameters on one module.
pub const MAX_PARAMS: usize = 8;
/// Derivation work budget (modules visited + expression nodes evaluated): bounds time.
pub const MAX_WORK: u64 = 300_000_000;

/// The turtle symbols (ABOP table 1.1 and §1.10): everything else a module may be is an ASCII
/// letter or digit.
pub const TURTLE_SYMBOLS: &str = "Ff+-&^\\/|$[]!'~%";

/// True for a byte that may name a module: ASCII letters, digits and the turtle symbols.
pub fn is_module_symbol(c: char) -> bool {
    c.is_ascii_alphanumeric() || TURTLE_SYMBOLS.contains(c)
}

/// Which texture the leaves (`~`) of a plant carry, and whether a `~` is a card carrying many
/// leaves (`Broadleaf`, `Needles`) or one real leaf (`Chestnut`, `Beech`: a leaf mesh of 4 or
/// 8 triangles, petiole included, with front, back and normal-map images).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LeafKind {
    /// A card with a cluster of nine broad serrated leaves (prunus, bush).
    #[default]
    Broadleaf,
    /// A card with a needle-covered shoot spray (pine).
    Needles,
    /// One sweet-chestnut leaf: oblong-lanceolate, coarsely serrated, on a short petiole.
    Chestnut,
    /// One beech leaf: ovate, wavy-edged, on a short petiole.
    Beech,
}

impl LeafKind {
    /// True for the kinds whose `~` is one leaf (meshed as a [`Blade`]), not a card.
    pub fn is_single_leaf(self) -> bool {
        matches!(self, LeafKind::Chestnut | LeafKind::Beech)
    }

    /// The blade used when the file has no `blade:` line.
    pub fn default_blade(self) -> Blade {
        match self {
            LeafKind::Chestnut => Blade {
                rows: 2,
                fold: 20.0,
                curl: 30.0,
            },
            LeafKind::Beech => Blade {
                rows: 1,
                fold: 12.0,
                curl: 0.0,
            },
            _ => Blade {
                rows: 0,
                fold: 0.0,
                curl: 0.0,
            },
        }
    }
}

/// How a single leaf (`~` with `leaves: chestnut` or `beech`) is meshed (`blade: ROWS FOLD
/// CURL`): a point at the petiole's base, `rows` rows of three vertices across the blade (left
/// edge, midrib, right edge), a point at the tip — 4 triangles for one row, 8 for two. The
/// halves rise by `fold` degrees from the midrib (a V), and the midrib bends by `curl` degrees
/// from base to tip towards the leaf's back (a drooping tip). Rows 0 means a flat card.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blade {
    /// Rows of vertices across the blade: 1 or 2 (0: the card quad of the card kinds).
    pub rows: u32,
    /// Fold of each half about the midrib, degrees (0–80).
    pub fold: f64,
    /// Bend of the midrib from base to tip, degrees (−90–90; positive droops the tip).
    pub curl: f64,
}

/// One module of a derived string: symbol, parameter count and offset into [`Word::params`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Module {
    /// ASCII symbol.
    pub sym: u8,
    /// Number of parameters.
    pub n: u8,
    /// Offset of the first parameter in [`Word::params`].
    pub off: u32,
}

/// A string of modules with their parameters, stored flat.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Word {
    /// The modules in order.
    pub modules: Vec<Module>,
    /// All parameters, module after module.
    pub params: Vec<f64>,
}

impl Word {
    /// Number of modules.
    pub fn len(&self) -> usize {
        self.modules.len()
    }

    /// True when there are no modules.
    pub fn is_empty(&self) -> bool {
        self.modules.is_empty()
    }

    /// Symbol of module `i`.
    pub fn sym(&self, i: usize) -> u8 {
        self.modules[i].sym
    }

    /// Parameters of module `i`.
    pub fn args(&self, i: usize) -> &[f64] {
        let m = self.modules[i];
        &self.params[m.off as usize..m.off as usize + m.n as usize]
    }

    /// Appends a module.
    pub fn push(&mut self, sym: u8, args: &[f64]) {
        self.modules.push(Module {
            sym,
            n: args.len() as u8,
            off: self.params.len() as u32,
        });
        self.params.extend_from_slice(args);
    }

    /// Number of modules with symbol `sym`.
    pub fn count(&self, sym: u8) -> usize {
        self.modules.iter().filter(|m| m.sym == sym).count()
    }

    /// For each bracket, the index of its partner (other modules: their own index).
    /// The word must be balanced (derived words always are).
    pub fn bracket_partners(&self) -> Vec<u32> {
        let mut out: Vec<u32> = (0..self.len() as u32).collect();
        let mut stack = Vec::new();
        for (i, m) in self.modules.iter().enumerate() {
            match m.sym {
                b'[' => stack.push(i),
                b']' => {
                    if let Some(o) = stack.pop() {
                        out[o] = i as u32;
                        out[i] = o as u32;
                    }
                }
                _ => {}
            }
        }
        out
    }
}

impl std::fmt::Display for Word {
    /// ABOP notation: `F(1,0.5)[+A(2)]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for i in 0..self.len() {
            write!(f, "{}", self.sym(i) as char)?;
            let a = self.args(i);
            if !a.is_empty() {
                write!(f, "(")?;
                for (k, v) in a.iter().enumerate() {
                    if k > 0 {
                        write!(f, ",")?;
                    }
                    write!(f, "{v}")?;
                }
                write!(f, ")")?;
            }
        }
        Ok(())
    }
}

/// A module pattern in a predecessor or context: symbol and parameter count.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    /// Symbol.
    pub sym: u8,
    /// Number of formal parameters.
    pub n: usize,
}

/// A module of a successor: symbol and argument expressions.
#[derive(Debug, Clone, PartialEq)]
pub struct SuccModule {
    /// Symbol.
    pub sym: u8,
    /// Argument expressions over the production's formal parameters.
    pub args: Vec<Expr>,
}

/// A production `LEFT < PRED > RIGHT : COND ->(WEIGHT) SUCC`.
#[derive(Debug, Clone, PartialEq)]
pub struct Production {
    /// Position of the predecessor in the file (for errors).
    pub pos: Pos,
    /// Left context, left to right (empty: none).
    pub left: Vec<Pattern>,
    /// The strict predecessor.
    pub pred: Pattern,
    /// Right context, left to right (empty: none).
    pub right: Vec<Pattern>,
    /// Condition; the production applies when it is non-zero.
    pub cond: Option<Expr>,
    /// Stochastic weight `->(w)`; `None` for a deterministic production.
    pub weight: Option<f64>,
    /// The successor.
    pub succ: Vec<SuccModule>,
    /// Cost of one application (expression nodes + modules), for [`MAX_WORK`].
    pub cost: u64,
}

/// A parsed `.lsys` file: header and productions.
#[derive(Debug, Clone, PartialEq)]
pub struct LSystem {
    /// File name used in error messages.
    pub file: String,
    /// `name:` (optional).
    pub name: Option<String>,
    /// `iterations:` derivation steps.
    pub iterations: u32,
    /// `angle:` default turn angle, degrees.
    pub angle: f64,
    /// `step:` default `F`/`f` length, metres (default 1).
    pub step: f64,
    /// `width:` initial branch diameter, metres (default `step / 10`).
    pub width: f64,
    /// `taper:` factor applied by `!` without a parameter (default 0.7).
    pub taper: f64,
    /// `leaf:` default `~` size (length of the leaf quad), metres (default `step / 2`).
    pub leaf_size: f64,
    /// `leaves:` the leaf texture kind.
    pub leaf_kind: LeafKind,
    /// `blade:` the mesh of a single leaf (the kind's default when absent; rows 0 for cards).
    pub blade: Blade,
    /// `twig:` thinnest branch diameter drawn as wood, metres (default 0: all). An `F` whose
    /// diameter is below it moves the turtle without drawing (leaf cards carry such twigs in
    /// their texture) and is not counted as an internode.
    pub twig: f64,
    /// `seed:` for stochastic productions (default 0).
    pub seed: u64,
    /// `limit:` most modules a derived string may hold (default [`DEFAULT_LIMIT`]).
    pub limit: usize,
    /// `tropism: x y z e`: direction and susceptibility (ABOP §2.3), or none.
    pub tropism: Option<([f64; 3], f64)>,
    /// `ignore:` symbols skipped when matching contexts.
    pub ignore: Vec<u8>,
    /// `axiom:` the initial string.
    pub axiom: Word,
    /// Productions in file order.
    pub productions: Vec<Production>,
}

impl LSystem {
    /// Parses `.lsys` source; `file` names it in errors (`FILE:LINE:COL: what — fix`).
    pub fn parse(src: &str, file: &str) -> Result<LSystem, crate::PlantError> {
        parse::parse(src, file)
    }

    /// Derives [`LSystem::iterations`] steps from the axiom.
    pub fn derive(&self) -> Result<Word, crate::PlantError> {
        self.derive_n(self.iterations)
    }

    /// Derives `n` steps from the axiom (`n` ≤ [`MAX_ITERATIONS`]).
    pub fn derive_n(&self, n: u32) -> Result<Word, crate::PlantError> {
        derive::derive(self, n)
    }
}
