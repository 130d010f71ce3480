//! A tiny markup for labels: italic math, subscripts and superscripts.
//!
//! - `$…$` is math: letters (Latin and Greek) inside are italic, digits and signs upright —
//!   as in TeX. `$L$_c` gives an italic L with an upright subscript c (the paper's L_c);
//!   `$L_c$` makes the c italic too.
//! - `_x` / `_{…}` is a subscript, `^x` / `^{…}` a superscript; they nest.
//! - `{…}` groups; `\` escapes the next character (`\$`, `\_`, `\^`, `\{`, `\\`).
//! - Everything else is literal Unicode: Greek (γ, ρ, ζ, υ, χ, β), −, ×, ≈, … all exist in the
//!   embedded DejaVu Sans.
//!
//! Examples: `"$γ$_0"` → γ₀, `"$p$ / $p$_{fc}"`, `"$Q$ (a.u.)"`, `"10^{-3}"`, `"$L$_c − $L$"`.

/// A run of text drawn with one font and one baseline shift.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The characters.
    pub text: String,
    /// Italic (math letters).
    pub italic: bool,
    /// Size relative to the base font.
    pub scale: f64,
    /// Baseline shift in base em, positive downwards.
    pub shift: f64,
}

/// Relative size of a sub- or superscript.
pub const SCRIPT_SCALE: f64 = 0.72;
/// Subscript baseline drop (in the parent's em).
pub const SUB_DROP: f64 = 0.24;
/// Superscript baseline rise (in the parent's em).
pub const SUP_RISE: f64 = 0.40;

#[derive(Clone, Copy)]
struct State {
    math: bool,
    scale: f64,
    shift: f64,
}

struct Parser<'a> {
    chars: std::iter::Peekable<std::str::Chars<'a>>,
    runs: Vec<Run>,
}

impl Parser<'_> {
    fn push(&mut self, c: char, st: &State) {
        let italic = st.math && c.is_alphabetic();
        if let Some(last) = self.runs.last_mut()
            && last.italic == italic
            && last.scale == st.scale
            && last.shift == st.shift
        {
            last.text.push(c);
            return;
        }
        self.runs.push(Run {
            text: c.to_string(),
            italic,
            scale: st.scale,
            shift: st.shift,
        });
    }

    /// Parses until the end or an unmatched `}` (consumed) when `in_group`. `$` toggles
    /// math mode for the rest of the group and what follows it at this level.
    fn seq(&mut self, st: &mut State, in_group: bool) {
        while let Some(c) = self.chars.next() {
            match c {
                '\\' => {
                    if let Some(n) = self.chars.next() {
                        self.push(n, st);
                    }
                }
                '$' => st.math = !st.math,
                '{' => {
                    let mut inner = *st;
                    self.seq(&mut inner, true);
                    st.math = inner.math;
                }
                '}' if in_group => return,
                '_' | '^' => {
                    let mut inner = State {
                        math: st.math,
                        scale: st.scale * SCRIPT_SCALE,
                        shift: if c == '_' {
                            st.shift + SUB_DROP * st.scale
                        } else {
                            st.shift - SUP_RISE * st.scale
                        },
                    };
                    match self.chars.next() {
                        Some('{') => self.seq(&mut inner, true),
                        Some('\\') => {
                            if let Some(n) = self.chars.next() {
                                self.push(n, &inner);
                            }
                        }
                        Some(n) => self.push(n, &inner),
                        None => {}
                    }
                }
                c => self.push(c, st),
            }
        }
    }
}

/// Splits marked-up text into runs.
pub fn parse(s: &str) -> Vec<Run> {
    let mut p = Parser {
        chars: s.chars().peekable(),
        runs: Vec::new(),
    };
    let mut st = State {
        math: false,
        scale: 1.0,
        shift: 0.0,
    };
    p.seq(&mut st, false);
    p.runs
}

/// The plain characters of marked-up text (markup removed), e.g. for SVG searches and file
/// metadata.
pub fn plain(s: &str) -> String {
    parse(s).into_iter().map(|r| r.text).collect()
}

/// Formats a number for a tick label or annotation with a typographic minus and `decimals`
/// digits after the point.
pub fn fmt_num(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    let s = if s.trim_start_matches(['-', '0', '.']).is_empty() {
        s.trim_start_matches('-').to_string()
    } else {
        s
    };
    s.replacen('-', "−", 1)
}

/// Formats a number with `sig` significant digits, using `a×10^{n}` markup for very large or
/// small magnitudes.
pub fn fmt_sig(x: f64, sig: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return if x.is_nan() {
            "NaN".into()
        } else {
            fmt_num(x, 0)
        };
    }
    let e = x.abs().log10().floor() as i32;
    if (-3..5).contains(&e) {
        let d = (sig as i32 - 1 - e).max(0) as usize;
        fmt_num(x, d)
    } else {
        let m = x / 10f64.powi(e);
        let d = sig.saturating_sub(1);
        format!("{}×10^{{{}}}", fmt_num(m, d), fmt_num(e as f64, 0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs() {
        let r = parse("$L$_c − $L$");
        assert_eq!(r.len(), 4);
        assert_eq!((r[0].text.as_str(), r[0].italic), ("L", true));
        assert_eq!((r[1].text.as_str(), r[1].italic), ("c", false));
        assert!(r[1].shift > 0.0 && r[1].scale < 1.0);
        assert_eq!(r[2].text, " − ");
        assert_eq!(plain("$γ$_0 = 10^{-3}"), "γ0 = 10-3");
        let r = parse("10^{-3}");
        assert_eq!(r[1].text, "-3");
        assert!(r[1].shift < 0.0);
        let r = parse("$x_{ab}$ \\$");
        assert!(r[1].italic && r[1].text == "ab");
        assert_eq!(r.last().unwrap().text, " $");
    }

    #[test]
    fn numbers() {
        assert_eq!(fmt_num(-0.5, 1), "−0.5");
        assert_eq!(fmt_num(-0.0001, 2), "0.00");
        assert_eq!(fmt_sig(1234.4, 3), "1234");
        assert_eq!(fmt_sig(2.5e-5, 2), "2.5×10^{−5}");
    }
}
