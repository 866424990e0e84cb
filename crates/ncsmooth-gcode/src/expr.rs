//! Real values, `[ ]` expressions and parameters, as RS274/NGC (LinuxCNC) defines them.
//!
//! A *real value* is a number, `#n` (a numbered parameter, `n` itself a real value that
//! must be an integer in `1..=5602`), `#<name>` (a named parameter: local, or global when
//! the name starts with `_`; white space inside the brackets is removed and case is
//! ignored, as LinuxCNC does), a bracketed expression, or a unary function
//! `ABS ACOS ASIN COS EXP FIX FUP LN ROUND SIN SQRT TAN` applied to a bracketed expression,
//! `ATAN[a]/[b]` (two-argument arctangent) or `EXISTS[#<name>]` (1 when the named
//! parameter is defined). A leading `+` or `-` is accepted before any real value.
//!
//! Binary operators, by decreasing precedence (left-associative within a level):
//! `**`; `*` `/` `MOD`; `+` `-`; `EQ NE GT GE LT LE`; `AND OR XOR`. Trigonometry is in
//! degrees, `ROUND` rounds half away from zero, `FIX` is floor, `FUP` ceiling, `MOD`
//! is non-negative for a positive divisor (as LinuxCNC). Comparisons and logic yield 1 or
//! 0. Any non-finite result of known operands (division by zero, `SQRT[-1]`, `LN[0]`,
//! overflow) is an [`ExpressionError`](ParseErrorKind::ExpressionError).
//!
//! # Unknown values
//!
//! Some parameters hold machine state that ncsmooth cannot know: the stored work offsets
//! (`#5221`..), home positions (`#5161`..), tool table entries, the position after a
//! `G53` move. Their lookup returns `UNKNOWN` (a NaN), which propagates through every
//! operator and function instead of being an error. The interpreter decides what an
//! unknown value means where it is used: an axis word makes that axis's position unknown,
//! a condition or any other word is an error naming the parameter.
//!
//! Parameters are evaluated with the values they had before the line (NGC: assignments
//! on a line take effect after the whole line is read). Reading a numbered parameter that
//! the program never set is an [`UndefinedParameter`](ParseErrorKind::UndefinedParameter)
//! error unless the lookup supplies a value (LinuxCNC reads its persistent parameter
//! file, which ncsmooth cannot know; a known-machine model supplies zeros).
//!
//! Nesting (brackets, `#` chains, signs) is limited to `MAX_DEPTH` so that hostile input
//! cannot overflow the stack.

use crate::cursor::{Cursor, LexError};
use crate::error::ParseErrorKind;

/// Deepest nesting of brackets, parameter references and signs.
pub(crate) const MAX_DEPTH: u32 = 64;

/// Highest numbered parameter (LinuxCNC's `RS274NGC_MAX_PARAMETERS - 1`).
pub const MAX_PARAM: u32 = 5602;

/// Longest parameter name (LinuxCNC's `LINELEN`-bounded names are far shorter in practice).
pub(crate) const MAX_NAME_LEN: usize = 255;

/// The value of a parameter that holds machine state ncsmooth cannot know. It is a NaN:
/// arithmetic on it stays unknown.
pub(crate) const UNKNOWN: f64 = f64::NAN;

/// Where parameter values come from while a line is evaluated.
pub trait ParamLookup {
    /// `#index`: `None` when never set, `UNKNOWN` when it holds unknown machine state.
    fn numbered(&self, index: u32) -> Option<f64>;
    /// `#<name>` (`name` upper case, without brackets or white space): `None` when not
    /// defined.
    fn named(&self, name: &[u8]) -> Option<f64>;
}

/// A plain parameter store: numbered parameters and named ones in one flat scope (what
/// the interpreter's scoped store reduces to for a single line), for the tests.
#[cfg(test)]
#[derive(Clone, Debug, Default)]
pub(crate) struct Params {
    values: Vec<Option<f64>>,
    named: std::collections::HashMap<Box<[u8]>, f64>,
}

#[cfg(test)]
impl Params {
    /// The value of `#index`, if it was set.
    pub fn get(&self, index: u32) -> Option<f64> {
        self.values.get(index as usize).copied().flatten()
    }
    /// Sets `#index` (`index <= MAX_PARAM`).
    pub fn set(&mut self, index: u32, value: f64) {
        let i = index as usize;
        if i >= self.values.len() {
            self.values.resize(i + 1, None);
        }
        self.values[i] = Some(value);
    }
    /// The value of `#<name>` (upper case), if it was set.
    pub fn get_named(&self, name: &[u8]) -> Option<f64> {
        self.named.get(name).copied()
    }
}

#[cfg(test)]
impl ParamLookup for Params {
    fn numbered(&self, index: u32) -> Option<f64> {
        self.get(index)
    }
    fn named(&self, name: &[u8]) -> Option<f64> {
        self.get_named(name)
    }
}

/// The parameter number for a real value, if it is (within 1e-6) an integer in range.
pub(crate) fn param_index(v: f64) -> Option<u32> {
    let r = v.round();
    if (v - r).abs() > 1e-6 || r < 1.0 || r > MAX_PARAM as f64 {
        return None;
    }
    Some(r as u32)
}

fn expr_err(c: &Cursor<'_>, why: &'static str, start: usize) -> LexError {
    c.error(
        ParseErrorKind::ExpressionError { why },
        start,
        c.pos.max(start + 1),
    )
}

/// `v` when finite or unknown (NaN from an unknown operand); an error otherwise.
fn finite(c: &Cursor<'_>, v: f64, start: usize, unknown_input: bool) -> Result<f64, LexError> {
    if v.is_finite() {
        Ok(v)
    } else if unknown_input {
        Ok(UNKNOWN)
    } else {
        Err(expr_err(c, "result is not a finite number", start))
    }
}

const FUNCS: [&[u8]; 14] = [
    b"ABS", b"ACOS", b"ASIN", b"ATAN", b"COS", b"EXISTS", b"EXP", b"FIX", b"FUP", b"LN", b"ROUND",
    b"SIN", b"SQRT", b"TAN",
];

/// Reads `<name>` at the cursor (which is on the `<`): the upper-case name, white space
/// already removed by the lexer. The cursor ends after the `>`.
pub(crate) fn read_name<'c>(c: &mut Cursor<'c>) -> Result<&'c [u8], LexError> {
    let start = c.pos;
    let buf: &'c [u8] = c.buf;
    let rest = &buf[start + 1..];
    let Some(len) = rest.iter().position(|&b| b == b'>') else {
        return Err(expr_err(c, "named parameter without closing '>'", start));
    };
    if len == 0 || len > MAX_NAME_LEN {
        return Err(expr_err(c, "empty or over-long parameter name", start));
    }
    c.pos = start + len + 2;
    Ok(&rest[..len])
}

/// Reads `#n` or `#<name>` at the cursor (on the `#`) and returns its value.
fn read_param<P: ParamLookup>(c: &mut Cursor<'_>, params: &P, depth: u32) -> Result<f64, LexError> {
    let start = c.pos;
    c.pos += 1;
    if c.peek() == Some(b'<') {
        let name = read_name(c)?;
        return params.named(name).ok_or_else(|| {
            c.error(
                ParseErrorKind::UndefinedNamedParameter {
                    name: String::from_utf8_lossy(name).to_lowercase(),
                },
                start,
                c.pos,
            )
        });
    }
    let idx_start = c.pos;
    let i = read_real_value(c, params, depth + 1, None)?;
    if i.is_nan() {
        return Ok(UNKNOWN);
    }
    let index =
        param_index(i).ok_or_else(|| c.error(ParseErrorKind::OutOfRange, idx_start, c.pos))?;
    params
        .numbered(index)
        .ok_or_else(|| c.error(ParseErrorKind::UndefinedParameter { index }, start, c.pos))
}

/// Reads a real value at the cursor. `letter` is the word letter it belongs to (for
/// the "missing value" error), `None` inside expressions.
pub(crate) fn read_real_value<P: ParamLookup>(
    c: &mut Cursor<'_>,
    params: &P,
    depth: u32,
    letter: Option<u8>,
) -> Result<f64, LexError> {
    let start = c.pos;
    if depth > MAX_DEPTH {
        return Err(expr_err(c, "nested too deeply", start));
    }
    // Unary signs (iterative).
    let mut neg = false;
    let mut signs = 0;
    while let Some(b @ (b'+' | b'-')) = c.peek() {
        signs += 1;
        if signs > MAX_DEPTH {
            return Err(expr_err(c, "too many signs", start));
        }
        if b == b'-' {
            neg = !neg;
        }
        c.pos += 1;
    }
    let missing = |c: &Cursor<'_>| match letter {
        Some(l) if l != b'#' => c.error(
            ParseErrorKind::MissingValue { letter: l as char },
            start.saturating_sub(1),
            start.max(1),
        ),
        _ => expr_err(c, "expected a value", start),
    };
    let v = match c.peek() {
        None => return Err(missing(c)),
        Some(b'0'..=b'9' | b'.') => c.read_number()?,
        Some(b'[') => {
            c.pos += 1;
            let v = read_expr(c, params, depth + 1)?;
            expect_close(c, start)?;
            v
        }
        Some(b'#') => read_param(c, params, depth)?,
        Some(b'A'..=b'Z') => {
            let Some(name) = FUNCS.iter().find(|f| c.starts_with(f)) else {
                return Err(missing(c));
            };
            // `ATAN` must not be mistaken for `A`-word + `TAN` etc.: a function name is
            // always followed by `[`.
            if c.peek_at(name.len()) != Some(b'[') {
                return Err(missing(c));
            }
            c.pos += name.len() + 1;
            if *name == b"EXISTS" {
                // EXISTS[#<name>]: whether the named parameter is defined; EXISTS[#n]:
                // whether n is a parameter number.
                if c.peek() != Some(b'#') {
                    return Err(expr_err(
                        c,
                        "EXISTS needs a parameter: EXISTS[#<name>]",
                        start,
                    ));
                }
                c.pos += 1;
                let defined = if c.peek() == Some(b'<') {
                    params.named(read_name(c)?).is_some()
                } else {
                    let i = read_real_value(c, params, depth + 1, None)?;
                    param_index(i).is_some()
                };
                expect_close(c, start)?;
                let v = if defined { 1.0 } else { 0.0 };
                return Ok(if neg { -v } else { v });
            }
            let a = read_expr(c, params, depth + 1)?;
            expect_close(c, start)?;
            let v = match *name {
                b"ABS" => a.abs(),
                b"ACOS" => a.acos().to_degrees(),
                b"ASIN" => a.asin().to_degrees(),
                b"COS" => a.to_radians().cos(),
                b"EXP" => a.exp(),
                b"FIX" => a.floor(),
                b"FUP" => a.ceil(),
                b"LN" => {
                    if a <= 0.0 && !a.is_nan() {
                        return Err(expr_err(c, "LN of a non-positive number", start));
                    }
                    a.ln()
                }
                b"ROUND" => a.round(),
                b"SIN" => a.to_radians().sin(),
                b"SQRT" => {
                    if a < 0.0 && !a.is_nan() {
                        return Err(expr_err(c, "SQRT of a negative number", start));
                    }
                    a.sqrt()
                }
                b"TAN" => a.to_radians().tan(),
                _ => {
                    // ATAN[a]/[b]
                    if c.peek() != Some(b'/') || c.peek_at(1) != Some(b'[') {
                        return Err(expr_err(c, "ATAN needs the form ATAN[a]/[b]", start));
                    }
                    c.pos += 2;
                    let b = read_expr(c, params, depth + 1)?;
                    expect_close(c, start)?;
                    if b.is_nan() {
                        UNKNOWN
                    } else {
                        a.atan2(b).to_degrees()
                    }
                }
            };
            finite(c, v, start, a.is_nan())?
        }
        Some(_) => return Err(missing(c)),
    };
    Ok(if neg { -v } else { v })
}

fn expect_close(c: &mut Cursor<'_>, start: usize) -> Result<(), LexError> {
    if c.peek() == Some(b']') {
        c.pos += 1;
        Ok(())
    } else {
        Err(expr_err(c, "missing ']'", start))
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Op {
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

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::Pow => 4,
            Op::Mul | Op::Div | Op::Mod => 3,
            Op::Add | Op::Sub => 2,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 1,
            Op::And | Op::Or | Op::Xor => 0,
        }
    }
}

fn read_op(c: &mut Cursor<'_>) -> Option<Op> {
    const WORDS: [(&[u8], Op); 13] = [
        (b"**", Op::Pow),
        (b"*", Op::Mul),
        (b"/", Op::Div),
        (b"MOD", Op::Mod),
        (b"+", Op::Add),
        (b"-", Op::Sub),
        (b"EQ", Op::Eq),
        (b"NE", Op::Ne),
        (b"GT", Op::Gt),
        (b"GE", Op::Ge),
        (b"LT", Op::Lt),
        (b"LE", Op::Le),
        (b"AND", Op::And),
    ];
    for (w, op) in WORDS {
        if c.starts_with(w) {
            c.pos += w.len();
            return Some(op);
        }
    }
    for (w, op) in [(&b"OR"[..], Op::Or), (b"XOR", Op::Xor)] {
        if c.starts_with(w) {
            c.pos += w.len();
            return Some(op);
        }
    }
    None
}

fn apply(c: &Cursor<'_>, op: Op, a: f64, b: f64, start: usize) -> Result<f64, LexError> {
    if a.is_nan() || b.is_nan() {
        // An unknown operand makes the result unknown, comparisons included.
        return Ok(UNKNOWN);
    }
    let t = |x: bool| if x { 1.0 } else { 0.0 };
    let v = match op {
        Op::Pow => a.powf(b),
        Op::Mul => a * b,
        Op::Div => {
            if b == 0.0 {
                return Err(expr_err(c, "division by zero", start));
            }
            a / b
        }
        Op::Mod => {
            if b == 0.0 {
                return Err(expr_err(c, "MOD by zero", start));
            }
            let m = a % b;
            if m < 0.0 {
                m + b.abs()
            } else {
                m
            }
        }
        Op::Add => a + b,
        Op::Sub => a - b,
        Op::Eq => t(a == b),
        Op::Ne => t(a != b),
        Op::Gt => t(a > b),
        Op::Ge => t(a >= b),
        Op::Lt => t(a < b),
        Op::Le => t(a <= b),
        Op::And => t(a != 0.0 && b != 0.0),
        Op::Or => t(a != 0.0 || b != 0.0),
        Op::Xor => t((a != 0.0) != (b != 0.0)),
    };
    finite(c, v, start, false)
}

/// Reads the inside of `[ ]` (without the brackets): operands and binary operators,
/// evaluated with an operator stack (shunting-yard, no recursion per operator).
fn read_expr<P: ParamLookup>(c: &mut Cursor<'_>, params: &P, depth: u32) -> Result<f64, LexError> {
    let start = c.pos;
    let mut vals: Vec<f64> = Vec::new();
    let mut ops: Vec<Op> = Vec::new();
    vals.push(read_real_value(c, params, depth, None)?);
    loop {
        if c.peek() == Some(b']') || c.peek().is_none() {
            break;
        }
        let op_start = c.pos;
        let Some(op) = read_op(c) else {
            return Err(expr_err(c, "expected an operator or ']'", op_start));
        };
        while let Some(&top) = ops.last() {
            if top.precedence() >= op.precedence() {
                ops.pop();
                let b = vals.pop().unwrap_or(0.0);
                let a = vals.pop().unwrap_or(0.0);
                vals.push(apply(c, top, a, b, start)?);
            } else {
                break;
            }
        }
        ops.push(op);
        vals.push(read_real_value(c, params, depth, None)?);
    }
    while let Some(top) = ops.pop() {
        let b = vals.pop().unwrap_or(0.0);
        let a = vals.pop().unwrap_or(0.0);
        vals.push(apply(c, top, a, b, start)?);
    }
    Ok(vals.pop().unwrap_or(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lexer::{compact_line, LineBuf};

    fn eval_with(s: &str, p: &Params) -> Result<f64, ParseErrorKind> {
        let mut lb = LineBuf::default();
        compact_line(s.as_bytes(), 0, &mut lb).map_err(|e| e.kind)?;
        let mut c = Cursor {
            buf: &lb.bytes,
            map: &lb.map,
            line_end: lb.line_end,
            pos: 0,
        };
        let v = read_real_value(&mut c, p, 0, None).map_err(|e| e.kind)?;
        assert_eq!(c.pos, lb.bytes.len(), "did not consume {s}");
        Ok(v)
    }
    fn eval(s: &str) -> f64 {
        eval_with(s, &Params::default()).unwrap()
    }

    #[test]
    fn arithmetic_and_precedence() {
        assert_eq!(eval("[1 + 2 * 3]"), 7.0);
        assert_eq!(eval("[[1 + 2] * 3]"), 9.0);
        assert_eq!(eval("[2 ** 3 ** 2]"), 64.0); // left-associative, as LinuxCNC
        assert_eq!(eval("[10 - 4 - 3]"), 3.0);
        assert_eq!(eval("[8 / 4 / 2]"), 1.0);
        assert_eq!(eval("-[2 * 3]"), -6.0);
        assert_eq!(eval("[-2 + 5]"), 3.0);
        assert_eq!(eval("[7 mod 3]"), 1.0);
        assert_eq!(eval("[-7 MOD 3]"), 2.0);
        assert_eq!(eval("[1 LT 2 AND 3 GT 2]"), 1.0);
        assert_eq!(eval("[1 EQ 2 OR 0]"), 0.0);
        assert_eq!(eval("[1 XOR 0]"), 1.0);
        assert_eq!(eval("[2 GE 2]"), 1.0);
        assert_eq!(eval("[1 + 2 LE 3]"), 1.0);
    }

    #[test]
    fn functions_in_degrees() {
        assert!((eval("sin[30]") - 0.5).abs() < 1e-15);
        assert!((eval("COS[60]") - 0.5).abs() < 1e-15);
        assert!((eval("TAN[45]") - 1.0).abs() < 1e-15);
        assert!((eval("ATAN[1]/[1]") - 45.0).abs() < 1e-12);
        assert!((eval("ATAN[1]/[-1]") - 135.0).abs() < 1e-12);
        assert!((eval("ACOS[0.5]") - 60.0).abs() < 1e-12);
        assert!((eval("ASIN[1]") - 90.0).abs() < 1e-12);
        assert_eq!(eval("ABS[-2.5]"), 2.5);
        assert_eq!(eval("SQRT[16]"), 4.0);
        assert_eq!(eval("EXP[0]"), 1.0);
        assert_eq!(eval("LN[1]"), 0.0);
        assert_eq!(eval("ROUND[2.5]"), 3.0);
        assert_eq!(eval("ROUND[-2.5]"), -3.0);
        assert_eq!(eval("FIX[-2.5]"), -3.0);
        assert_eq!(eval("FUP[2.1]"), 3.0);
    }

    #[test]
    fn parameters() {
        let mut p = Params::default();
        p.set(2, -1.5);
        p.set(100, 2.0);
        assert_eq!(eval_with("#2", &p).unwrap(), -1.5);
        assert_eq!(eval_with("-#2", &p).unwrap(), 1.5);
        assert_eq!(eval_with("[#2 * #100]", &p).unwrap(), -3.0);
        assert_eq!(eval_with("##100", &p).unwrap(), -1.5); // #[#100] = #2
        assert_eq!(
            eval_with("#3", &p).unwrap_err(),
            ParseErrorKind::UndefinedParameter { index: 3 }
        );
        assert_eq!(eval_with("#0", &p).unwrap_err(), ParseErrorKind::OutOfRange);
        assert_eq!(
            eval_with("#1.5", &p).unwrap_err(),
            ParseErrorKind::OutOfRange
        );
    }

    #[test]
    fn expression_errors() {
        for s in [
            "[1/0]",
            "[1+]",
            "[1 #2]",
            "[1",
            "SQRT[-1]",
            "LN[0]",
            "ACOS[2]",
            "ATAN[1]",
            "[5 MOD 0]",
            "[10**400]",
        ] {
            assert!(
                matches!(
                    eval_with(s, &Params::default()),
                    Err(ParseErrorKind::ExpressionError { .. })
                ),
                "{s}"
            );
        }
        let deep = format!("{}1{}", "[".repeat(200), "]".repeat(200));
        assert!(eval_with(&deep, &Params::default()).is_err());
        let signs = format!("{}1", "-".repeat(10_000));
        assert!(eval_with(&signs, &Params::default()).is_err());
    }
}
