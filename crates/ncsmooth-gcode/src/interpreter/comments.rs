//! Comments and active comments (LinuxCNC's `convert_comment`): the last `( )` comment of
//! a block is passed to the controller before anything else in the block.
//!
//! * `(MSG,text)`: an operator message.
//! * `(DEBUG,text)` and `(PRINT,text)`, `(LOG,text)`: a message with parameters
//!   substituted (`#5420`, `#<_x>`, formatted `%lf`; `%d` and `%f` / `%.Nf` change the
//!   format of the parameters that follow, as LinuxCNC's `convert_param_comment` does).
//! * `(ABORT,text)`: the controller stops the program with that error; ncsmooth ends the
//!   program there and warns.
//! * `(LOGOPEN,..)`, `(LOGAPPEND,..)`, `(LOGCLOSE)`, `(PY,..)` and the like: kept, no
//!   effect on motion.
//! * anything else: a plain comment.
//!
//! Comments are [`EventKind::Comment`]/[`EventKind::Message`] events: they never move the
//! machine; they end a smoothing chain so that the point where the controller shows them
//! stays exact.

use super::Interp;
use crate::canon::Canon;
use crate::error::ParseError;
use crate::expr::ParamLookup;
use ncsmooth::path::EventKind;

/// What an active comment does.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    Msg,
    Debug,
    Print,
    /// `(LOG,...)`: like `PRINT`, but to LinuxCNC's log file.
    Log,
    Abort,
    Other,
    Plain,
}

fn classify(text: &str) -> (Kind, usize) {
    let lower: String = text
        .chars()
        .take(12)
        .collect::<String>()
        .to_ascii_lowercase();
    for (p, k) in [
        ("msg,", Kind::Msg),
        ("debug,", Kind::Debug),
        ("print,", Kind::Print),
        ("log,", Kind::Log),
        ("abort,", Kind::Abort),
        ("logopen,", Kind::Other),
        ("logappend,", Kind::Other),
        ("py,", Kind::Other),
        ("pyrun,", Kind::Other),
    ] {
        if lower.starts_with(p) {
            return (k, p.len());
        }
    }
    if lower == "logclose" || lower.starts_with("pyreload") {
        return (Kind::Other, 0);
    }
    (Kind::Plain, 0)
}

impl Interp<'_> {
    /// Handles the comment of the current line, if any.
    pub(crate) fn comment(&mut self) -> Result<(), ParseError> {
        let Some((s, e)) = self.lb.comment else {
            return Ok(());
        };
        let raw = &self.raw[s - self.raw_start..e - self.raw_start];
        let text = raw.trim_start();
        let (kind, skip) = classify(text);
        let body = &text[skip..];
        match kind {
            Kind::Plain => {
                let t = text.to_string();
                self.canon(|_| Canon::Comment(t.clone()));
                self.event(EventKind::Comment, t);
            }
            Kind::Msg => {
                let t = body.to_string();
                self.canon(|_| Canon::Message(t.clone()));
                self.event(EventKind::Message, t);
            }
            Kind::Debug | Kind::Print | Kind::Log => {
                let t = expand(self, body);
                match kind {
                    Kind::Debug => self.canon(|_| Canon::Message(t.clone())),
                    Kind::Print => self.canon(|_| Canon::Print(t.clone())),
                    _ => {}
                }
                self.event(EventKind::Message, t);
            }
            Kind::Abort => {
                let t = expand(self, body);
                self.warn(format!(
                    "(ABORT) the controller stops the program here: {t}"
                ));
                self.event(EventKind::Message, t);
                self.end_program();
            }
            Kind::Other => {
                self.event(EventKind::Message, text.to_string());
            }
        }
        Ok(())
    }
}

/// `body` with `#n` and `#<name>` replaced by their values (LinuxCNC's formats).
fn expand(it: &Interp<'_>, body: &str) -> String {
    let b = body.as_bytes();
    let mut out = String::with_capacity(body.len() + 16);
    let mut decimals: usize = 6;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                i += 1;
                match b.get(i) {
                    Some(b'd') => {
                        decimals = 0;
                        i += 1;
                    }
                    Some(b'f') => {
                        decimals = 4;
                        i += 1;
                    }
                    Some(b'.')
                        if b.get(i + 1).is_some_and(u8::is_ascii_digit)
                            && b.get(i + 2) == Some(&b'f') =>
                    {
                        decimals = usize::from(b[i + 1] - b'0');
                        i += 3;
                    }
                    Some(b'.') => {
                        out.push('.');
                        i += 1;
                    }
                    _ => out.push('%'),
                }
            }
            b'#' => {
                i += 1;
                let value = if b.get(i).is_some_and(u8::is_ascii_digit) {
                    let st = i;
                    while b.get(i).is_some_and(u8::is_ascii_digit) {
                        i += 1;
                    }
                    body[st..i].parse::<u32>().ok().and_then(|n| it.numbered(n))
                } else if b.get(i) == Some(&b'<') {
                    let st = i + 1;
                    let Some(len) = b[st..].iter().position(|&c| c == b'>') else {
                        out.push_str("######");
                        break;
                    };
                    let name: Vec<u8> = b[st..st + len]
                        .iter()
                        .filter(|c| !c.is_ascii_whitespace())
                        .map(u8::to_ascii_uppercase)
                        .collect();
                    i = st + len + 1;
                    it.named(&name)
                } else {
                    out.push('#');
                    continue;
                };
                match value {
                    Some(v) if v.is_nan() => out.push_str("(unknown)"),
                    Some(v) => {
                        let v = if v.abs() < 1e-12 { 0.0 } else { v };
                        out.push_str(&format!("{v:.decimals$}"));
                    }
                    None => out.push_str("######"),
                }
            }
            _ => {
                let ch = body[i..].chars().next().unwrap_or('?');
                out.push(ch);
                i += ch.len_utf8();
            }
        }
    }
    out
}
