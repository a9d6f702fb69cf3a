//! Values of words: numbers, parameters (`#12`, `#<name>`) and `[expr]` arithmetic with the
//! functions of RS274/NGC (angles in degrees, as LinuxCNC).

use std::collections::HashMap;

/// A parameter reference.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Param {
    /// `#n`, `#[expr]`: a numbered parameter.
    Numbered(Box<Expr>),
    /// `#<name>`: a named parameter (lower case, spaces removed).
    Named(String),
}

/// Binary operators, LinuxCNC precedence (higher binds tighter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum BinOp {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl BinOp {
    pub(crate) fn precedence(self) -> u8 {
        match self {
            BinOp::Pow => 6,
            BinOp::Mul | BinOp::Div | BinOp::Mod => 5,
            BinOp::Add | BinOp::Sub => 4,
            BinOp::Eq | BinOp::Ne | BinOp::Gt | BinOp::Ge | BinOp::Lt | BinOp::Le => 3,
            BinOp::And | BinOp::Or | BinOp::Xor => 2,
        }
    }

    /// The operator spelled by `name` (lower case letters), if any.
    pub(crate) fn named(name: &str) -> Option<BinOp> {
        Some(match name {
            "mod" => BinOp::Mod,
            "eq" => BinOp::Eq,
            "ne" => BinOp::Ne,
            "gt" => BinOp::Gt,
            "ge" => BinOp::Ge,
            "lt" => BinOp::Lt,
            "le" => BinOp::Le,
            "and" => BinOp::And,
            "or" => BinOp::Or,
            "xor" => BinOp::Xor,
            _ => return None,
        })
    }
}

/// Unary functions `name[expr]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Func {
    Abs,
    Acos,
    Asin,
    Cos,
    Exp,
    Fix,
    Fup,
    Round,
    Ln,
    Sin,
    Sqrt,
    Tan,
}

impl Func {
    pub(crate) fn named(name: &str) -> Option<Func> {
        Some(match name {
            "abs" => Func::Abs,
            "acos" => Func::Acos,
            "asin" => Func::Asin,
            "cos" => Func::Cos,
            "exp" => Func::Exp,
            "fix" => Func::Fix,
            "fup" => Func::Fup,
            "round" => Func::Round,
            "ln" => Func::Ln,
            "sin" => Func::Sin,
            "sqrt" => Func::Sqrt,
            "tan" => Func::Tan,
            _ => return None,
        })
    }
}

/// A word's value before evaluation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Num(f64),
    Param(Param),
    Neg(Box<Expr>),
    Bin(BinOp, Box<Expr>, Box<Expr>),
    Func(Func, Box<Expr>),
    /// `atan[y]/[x]`, degrees.
    Atan(Box<Expr>, Box<Expr>),
    /// `exists[#<name>]`: 1 if the named parameter is set.
    Exists(String),
}

/// The parameter store: numbered (`#1`–`#5999`, unset reads 0) and named (unset is an error).
#[derive(Debug, Clone, Default)]
pub(crate) struct Params {
    pub numbered: HashMap<i64, f64>,
    pub named: HashMap<String, f64>,
}

/// Largest numbered parameter, as LinuxCNC's `RS274NGC_MAX_PARAMETERS − 1`.
pub(crate) const MAX_PARAM: i64 = 5601;

impl Params {
    /// The index of a numbered parameter, checked.
    pub(crate) fn index(&self, e: &Expr) -> Result<i64, String> {
        let v = e.eval(self)?;
        let i = v.round();
        if (v - i).abs() > 1e-4 || !(1.0..=MAX_PARAM as f64).contains(&i) {
            return Err(format!(
                "parameter number {v} is not an integer in 1..={MAX_PARAM}"
            ));
        }
        Ok(i as i64)
    }

    pub(crate) fn get(&self, p: &Param) -> Result<f64, String> {
        match p {
            Param::Numbered(e) => Ok(self.numbered.get(&self.index(e)?).copied().unwrap_or(0.0)),
            Param::Named(n) => self
                .named
                .get(n)
                .copied()
                .ok_or_else(|| format!("named parameter #<{n}> is not defined")),
        }
    }
}

impl Expr {
    /// The value of an expression that reads no parameter (`None` if it reads one or does
    /// not evaluate).
    pub(crate) fn constant(&self) -> Option<f64> {
        fn reads(e: &Expr) -> bool {
            match e {
                Expr::Num(_) => false,
                Expr::Param(_) | Expr::Exists(_) => true,
                Expr::Neg(a) | Expr::Func(_, a) => reads(a),
                Expr::Bin(_, a, b) | Expr::Atan(a, b) => reads(a) || reads(b),
            }
        }
        if reads(self) {
            return None;
        }
        self.eval(&Params::default()).ok()
    }

    /// The value of the expression with the parameters `p`.
    pub(crate) fn eval(&self, p: &Params) -> Result<f64, String> {
        let v = match self {
            Expr::Num(v) => *v,
            Expr::Param(par) => p.get(par)?,
            Expr::Neg(e) => -e.eval(p)?,
            Expr::Exists(n) => f64::from(u8::from(p.named.contains_key(n))),
            Expr::Atan(y, x) => y.eval(p)?.atan2(x.eval(p)?).to_degrees(),
            Expr::Func(f, e) => {
                let a = e.eval(p)?;
                match f {
                    Func::Abs => a.abs(),
                    Func::Acos | Func::Asin if !(-1.0..=1.0).contains(&a) => {
                        return Err(format!("argument {a} of ACOS/ASIN is outside [-1, 1]"))
                    }
                    Func::Acos => a.acos().to_degrees(),
                    Func::Asin => a.asin().to_degrees(),
                    Func::Cos => a.to_radians().cos(),
                    Func::Exp => a.exp(),
                    Func::Fix => a.floor(),
                    Func::Fup => a.ceil(),
                    Func::Round => a.round(),
                    Func::Ln if a <= 0.0 => return Err(format!("LN of {a} (needs > 0)")),
                    Func::Ln => a.ln(),
                    Func::Sin => a.to_radians().sin(),
                    Func::Sqrt if a < 0.0 => return Err(format!("SQRT of {a} (needs >= 0)")),
                    Func::Sqrt => a.sqrt(),
                    Func::Tan => a.to_radians().tan(),
                }
            }
            Expr::Bin(op, l, r) => {
                let (a, b) = (l.eval(p)?, r.eval(p)?);
                let t = |c: bool| f64::from(u8::from(c));
                match op {
                    BinOp::Pow => a.powf(b),
                    BinOp::Mul => a * b,
                    BinOp::Div if b == 0.0 => return Err("division by zero".into()),
                    BinOp::Div => a / b,
                    BinOp::Mod if b == 0.0 => return Err("MOD by zero".into()),
                    BinOp::Mod => a.rem_euclid(b.abs()),
                    BinOp::Add => a + b,
                    BinOp::Sub => a - b,
                    BinOp::Eq => t(a == b),
                    BinOp::Ne => t(a != b),
                    BinOp::Gt => t(a > b),
                    BinOp::Ge => t(a >= b),
                    BinOp::Lt => t(a < b),
                    BinOp::Le => t(a <= b),
                    BinOp::And => t(a != 0.0 && b != 0.0),
                    BinOp::Or => t(a != 0.0 || b != 0.0),
                    BinOp::Xor => t((a != 0.0) != (b != 0.0)),
                }
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err("the result is not a finite number".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(v: f64) -> Box<Expr> {
        Box::new(Expr::Num(v))
    }

    #[test]
    fn functions_work_in_degrees() {
        let p = Params::default();
        let atan = Expr::Atan(num(1.0), num(1.0));
        assert!((atan.eval(&p).expect("ok") - 45.0).abs() < 1e-12);
        let sin = Expr::Func(Func::Sin, num(30.0));
        assert!((sin.eval(&p).expect("ok") - 0.5).abs() < 1e-12);
    }

    #[test]
    fn division_by_zero_is_an_error() {
        let p = Params::default();
        assert!(Expr::Bin(BinOp::Div, num(1.0), num(0.0)).eval(&p).is_err());
    }

    #[test]
    fn unset_numbered_reads_zero_unset_named_fails() {
        let p = Params::default();
        assert_eq!(p.get(&Param::Numbered(num(7.0))).expect("ok"), 0.0);
        assert!(p.get(&Param::Named("x".into())).is_err());
    }
}
