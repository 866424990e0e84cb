//! One block's words: sorted into G codes, M codes and letter slots, checked against
//! LinuxCNC's modal groups.

use super::Interp;
use crate::error::{ParseError, ParseErrorKind};
use std::fmt::Write as _;

/// Most M codes LinuxCNC accepts in one block.
pub(crate) const MAX_M_CODES_PER_BLOCK: usize = 4;
/// Number of G modal groups [`g_modal_group`] distinguishes.
const G_GROUPS: usize = 16;
/// Number of M modal groups [`m_modal_group`] distinguishes.
const M_GROUPS: usize = 4;
/// Letter slots: `A`..`Z`, then `@` (polar radius) and `^` (polar angle).
pub(crate) const N_SLOTS: usize = 28;

/// Letters of the slots (slot `i` holds letter `SLOT_LETTERS[i]`).
pub(crate) const SLOT_LETTERS: &[u8; N_SLOTS] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZ@^";

/// The slot mask of `letters`.
const fn slot_mask(letters: &[u8]) -> u32 {
    let mut m = 0u32;
    let mut i = 0;
    while i < letters.len() {
        m |= 1 << slot(letters[i]);
        i += 1;
    }
    m
}

/// Slots of the words a motion line rewritten by the writer may carry: axes, centre and
/// spline words (I J K R P Q), F and the polar words.
pub(crate) const MOTION_LETTER_SLOTS: u32 = slot_mask(b"XYZABCUVWEIJKRPQF@^");

/// Slots of words that are an error when no code of the block uses them (LinuxCNC).
pub(crate) const MUST_USE_SLOTS: u32 = slot_mask(b"DHIJKLPQR");
/// Slot of `@`.
pub(crate) const SLOT_AT: usize = 26;
/// Slot of `^`.
pub(crate) const SLOT_CARET: usize = 27;

/// A located code word of the block (`code10`: the code in tenths, `G90.1` is 901).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Code {
    pub code10: u32,
    pub word: usize,
}

/// The slot of a word letter.
#[inline]
pub(crate) const fn slot(letter: u8) -> usize {
    match letter {
        b'@' => SLOT_AT,
        b'^' => SLOT_CARET,
        l => (l - b'A') as usize,
    }
}

/// Formats a G/M code stored as tenths (`901` -> `G90.1`), appended after a space.
pub(crate) fn push_code(s: &mut String, letter: char, code10: u32) {
    if !s.is_empty() {
        s.push(' ');
    }
    s.push(letter);
    let _ = write!(s, "{}", code10 / 10);
    if code10 % 10 != 0 {
        let _ = write!(s, ".{}", code10 % 10);
    }
}

/// A code as text (`G90.1`).
pub(crate) fn code_name(letter: char, code10: u32) -> String {
    let mut s = String::new();
    push_code(&mut s, letter, code10);
    s
}

/// Appends ` L<value>`.
pub(crate) fn push_word(s: &mut String, letter: u8, v: f64) {
    if !s.is_empty() {
        s.push(' ');
    }
    s.push(letter as char);
    crate::numbers::push_fixed(s, v, 10);
}

/// LinuxCNC's modal group of a G code (tenths), as an index below [`G_GROUPS`]; `None`
/// for codes outside the groups. Group 0 (non-modal codes: G4, G10, G28, G30, G53, G92,
/// ...) also allows only one code per block.
pub(crate) fn g_modal_group(code10: u32) -> Option<usize> {
    Some(match code10 {
        40 | 100 | 280 | 281 | 300 | 301 | 520 | 530 | 920..=923 => 0,
        // G80 is left out: `G80 G00` in CAM headers is accepted (see the module doc).
        0
        | 10
        | 20
        | 30
        | 50
        | 51
        | 52
        | 53
        | 330
        | 331
        | 382..=385
        | 730
        | 740
        | 760
        | 810..=890 => 1,
        170 | 171 | 180 | 181 | 190 | 191 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 411 | 420 | 421 => 7,
        430..=432 | 490 => 8,
        980 | 990 => 9,
        540..=593 => 10,
        610 | 611 | 640 => 11,
        960 | 970 => 12,
        70 | 80 => 13,
        150 | 160 => 14,
        _ => return None,
    })
}

/// LinuxCNC's modal group of an M code (tenths): stops (M0 M1 M2 M30 M60 M99), tool change
/// (M6), spindle (M3 M4 M5), coolant (M7 M8 M9).
fn m_modal_group(code10: u32) -> Option<usize> {
    Some(match code10 {
        0 | 10 | 20 | 300 | 600 | 990 => 0,
        60 => 1,
        30 | 40 | 50 => 2,
        70 | 80 | 90 => 3,
        _ => return None,
    })
}

impl Interp<'_> {
    /// Sorts the words of the block into codes and letter slots.
    // Inlined into `block` on the hot path (a second caller, `M98`, made LLVM call it:
    // +1.9 % instructions parsing stellabee1).
    #[inline(always)]
    pub(crate) fn classify(&mut self) -> Result<(), ParseError> {
        self.gcodes.clear();
        self.mcodes.clear();
        self.letters = [None; N_SLOTS];
        self.present = 0;
        self.used = 0;
        for i in 0..self.words.len() {
            let w = self.words[i];
            match w.letter {
                b'G' | b'M' => {
                    if w.value.is_nan() {
                        return Err(self.err_word(
                            i,
                            ParseErrorKind::UnknownValue {
                                what: format!("the {} code", w.letter as char),
                            },
                        ));
                    }
                    let t = w.value * 10.0;
                    let r = t.round();
                    if (t - r).abs() > 1e-3 || !(0.0..=1e6).contains(&r) {
                        let mut word = String::new();
                        push_word(&mut word, w.letter, w.value);
                        return Err(self.err_word(i, ParseErrorKind::UnknownWord { word }));
                    }
                    let c = Code {
                        code10: r as u32,
                        word: i,
                    };
                    if w.letter == b'G' {
                        self.gcodes.push(c);
                    } else {
                        self.mcodes.push(c);
                    }
                }
                b'N' => {}
                l => {
                    let k = slot(l);
                    if self.letters[k].is_some() {
                        return Err(
                            self.err_word(i, ParseErrorKind::DuplicateWord { letter: l as char })
                        );
                    }
                    self.letters[k] = Some(i);
                    self.present |= 1 << k;
                }
            }
        }
        Ok(())
    }

    /// Rejects two codes of one modal group in a block (LinuxCNC: "two G codes used from
    /// same modal group"; M7 with M8 is the one allowed pair) and more than
    /// [`MAX_M_CODES_PER_BLOCK`] M codes.
    pub(crate) fn check_modal_groups(&self) -> Result<(), ParseError> {
        let mut g_seen: [Option<Code>; G_GROUPS] = [None; G_GROUPS];
        for &c in &self.gcodes {
            if let Some(g) = g_modal_group(c.code10) {
                if let Some(prev) = g_seen[g] {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::ModalConflict {
                            first: code_name('G', prev.code10),
                            second: code_name('G', c.code10),
                        },
                    ));
                }
                g_seen[g] = Some(c);
            }
        }
        if self.mcodes.len() > MAX_M_CODES_PER_BLOCK {
            let c = self.mcodes[MAX_M_CODES_PER_BLOCK];
            return Err(self.err_word(
                c.word,
                ParseErrorKind::InvalidValue {
                    letter: 'M',
                    value: f64::from(c.code10) / 10.0,
                    why: "more than 4 M codes in one block",
                },
            ));
        }
        let mut m_seen: [Option<Code>; M_GROUPS] = [None; M_GROUPS];
        for &c in &self.mcodes {
            if let Some(g) = m_modal_group(c.code10) {
                if let Some(prev) = m_seen[g] {
                    let mist_and_flood = matches!((prev.code10, c.code10), (70, 80) | (80, 70));
                    if !mist_and_flood {
                        return Err(self.err_word(
                            c.word,
                            ParseErrorKind::ModalConflict {
                                first: code_name('M', prev.code10),
                                second: code_name('M', c.code10),
                            },
                        ));
                    }
                }
                m_seen[g] = Some(c);
            }
        }
        Ok(())
    }

    /// The value of letter `l` (raw, in program units), marking it used. `None` when the
    /// block has no such word.
    #[inline]
    pub(crate) fn val(&mut self, l: u8) -> Option<f64> {
        let i = slot(l);
        let w = self.letters[i]?;
        self.used |= 1 << i;
        Some(self.words[w].value)
    }

    /// True when the block has letter `l`.
    #[inline]
    pub(crate) fn has(&self, l: u8) -> bool {
        self.letters[slot(l)].is_some()
    }

    /// Index of the word of letter `l` (the first word when absent, for error spans).
    #[inline]
    pub(crate) fn word_of(&self, l: u8) -> usize {
        self.letters[slot(l)].unwrap_or(0)
    }

    /// The G code of group `code10` in the block, if any.
    pub(crate) fn gcode(&self, pred: impl Fn(u32) -> bool) -> Option<Code> {
        self.gcodes.iter().copied().find(|c| pred(c.code10))
    }

    /// The M code matching `pred`, if any.
    pub(crate) fn mcode(&self, pred: impl Fn(u32) -> bool) -> Option<Code> {
        self.mcodes.iter().copied().find(|c| pred(c.code10))
    }

    /// A known value of letter `l`, or an error when it depends on unknown machine state.
    pub(crate) fn known_val(&mut self, l: u8) -> Result<Option<f64>, ParseError> {
        match self.val(l) {
            Some(v) if v.is_nan() => Err(self.err_word(
                self.word_of(l),
                ParseErrorKind::UnknownValue {
                    what: format!("the {} word", l as char),
                },
            )),
            v => Ok(v),
        }
    }
}
