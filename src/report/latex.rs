//! LaTeX escaping: text → something pdflatex and lualatex both typeset. Greek letters and math
//! symbols (common in parameter names: σ, θ, ρ, Δ, ≥) become math-mode commands.

/// U+0302, as in "N̂eff".
const COMBINING_CIRCUMFLEX: char = '\u{302}';

pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 8);
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        // a letter with a combining circumflex (N̂eff): \hat in math mode
        if chars.peek() == Some(&COMBINING_CIRCUMFLEX) && c.is_ascii_alphabetic() {
            chars.next();
            out.push_str(&format!("\\ensuremath{{\\hat{{{c}}}}}"));
            continue;
        }
        match c {
            '\\' => out.push_str("\\textbackslash{}"),
            '{' => out.push_str("\\{"),
            '}' => out.push_str("\\}"),
            '$' => out.push_str("\\$"),
            '&' => out.push_str("\\&"),
            '%' => out.push_str("\\%"),
            '#' => out.push_str("\\#"),
            '_' => out.push_str("\\_"),
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '<' => out.push_str("\\textless{}"),
            '>' => out.push_str("\\textgreater{}"),
            '|' => out.push_str("\\textbar{}"),
            '"' => out.push_str("\\textquotedbl{}"),
            '–' => out.push_str("--"),
            '—' => out.push_str("---"),
            '‘' => out.push('`'),
            '’' => out.push('\''),
            '“' => out.push_str("``"),
            '”' => out.push_str("''"),
            '…' => out.push_str("\\ldots{}"),
            '°' => out.push_str("\\ensuremath{^\\circ}"),
            '²' => out.push_str("\\ensuremath{^2}"),
            '³' => out.push_str("\\ensuremath{^3}"),
            '·' => out.push_str("\\ensuremath{\\cdot}"),
            '×' => out.push_str("\\ensuremath{\\times}"),
            '±' => out.push_str("\\ensuremath{\\pm}"),
            '−' => out.push_str("\\ensuremath{-}"),
            '≤' => out.push_str("\\ensuremath{\\leq}"),
            '≥' => out.push_str("\\ensuremath{\\geq}"),
            '≈' => out.push_str("\\ensuremath{\\approx}"),
            '≪' => out.push_str("\\ensuremath{\\ll}"),
            '≫' => out.push_str("\\ensuremath{\\gg}"),
            '≠' => out.push_str("\\ensuremath{\\neq}"),
            '→' => out.push_str("\\ensuremath{\\rightarrow}"),
            '←' => out.push_str("\\ensuremath{\\leftarrow}"),
            '∞' => out.push_str("\\ensuremath{\\infty}"),
            '√' => out.push_str("\\ensuremath{\\surd}"),
            '⊕' => out.push_str("\\ensuremath{\\oplus}"),
            '⊖' => out.push_str("\\ensuremath{\\ominus}"),
            '∈' => out.push_str("\\ensuremath{\\in}"),
            '∝' => out.push_str("\\ensuremath{\\propto}"),
            '§' => out.push_str("\\S{}"),
            'ᵀ' => out.push_str("\\ensuremath{^{\\top}}"),
            '⁻' => out.push_str("\\ensuremath{^{-}}"),
            '⁺' => out.push_str("\\ensuremath{^{+}}"),
            c @ ('⁰' | '¹' | '⁴' | '⁵' | '⁶' | '⁷' | '⁸' | '⁹') => {
                let d = "⁰¹²³⁴⁵⁶⁷⁸⁹".chars().position(|x| x == c).expect("a superscript digit");
                out.push_str(&format!("\\ensuremath{{^{d}}}"));
            }
            c @ '₀'..='₉' => {
                let d = c as u32 - '₀' as u32;
                out.push_str(&format!("\\ensuremath{{_{d}}}"));
            }
            'ᵢ' => out.push_str("\\ensuremath{_i}"),
            '\u{a0}' => out.push('~'),
            c if greek(c).is_some() => {
                out.push_str("\\ensuremath{\\");
                out.push_str(greek(c).expect("checked"));
                out.push('}');
            }
            c if c.is_ascii() => out.push(c),
            // Anything else: keep it; lualatex typesets it, pdflatex with utf8 input mostly does.
            c => out.push(c),
        }
    }
    out
}

fn greek(c: char) -> Option<&'static str> {
    Some(match c {
        'α' => "alpha",
        'β' => "beta",
        'γ' => "gamma",
        'δ' => "delta",
        'ε' => "varepsilon",
        'η' => "eta",
        'θ' => "theta",
        'κ' => "kappa",
        'λ' => "lambda",
        'μ' => "mu",
        'ν' => "nu",
        'π' => "pi",
        'ρ' => "rho",
        'σ' => "sigma",
        'τ' => "tau",
        'φ' => "varphi",
        'χ' => "chi",
        'ψ' => "psi",
        'ω' => "omega",
        'Δ' => "Delta",
        'Θ' => "Theta",
        'Σ' => "Sigma",
        'Φ' => "Phi",
        'Ω' => "Omega",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specials_and_symbols() {
        assert_eq!(escape("a_b & 50% #1 $x$"), "a\\_b \\& 50\\% \\#1 \\$x\\$");
        assert_eq!(escape("σ ≥ 0"), "\\ensuremath{\\sigma} \\ensuremath{\\geq} 0");
        assert_eq!(escape("{x}\\"), "\\{x\\}\\textbackslash{}");
        // [EP]'s "σ ∝ range" broke pdflatex ("Unicode character ∝ (U+221D)")
        assert_eq!(escape("σ ∝ r"), "\\ensuremath{\\sigma} \\ensuremath{\\propto} r");
        // the scoreboard's "E-PSM ≈ CRS2 ≪ ISRES" broke it too ("Unicode character ≪ (U+226A)")
        assert_eq!(escape("a ≪ b ≫ c"), "a \\ensuremath{\\ll} b \\ensuremath{\\gg} c");
    }

    #[test]
    fn hats_superscripts_and_subscripts_become_math() {
        // these broke pdflatex ("Unicode character ̂ (U+0302) not set up")
        assert_eq!(escape("N̂eff"), "\\ensuremath{\\hat{N}}eff");
        assert_eq!(escape("eᵀP⁻¹e"), "e\\ensuremath{^{\\top}}P\\ensuremath{^{-}}\\ensuremath{^1}e");
        assert_eq!(escape("χ²₃"), "\\ensuremath{\\chi}\\ensuremath{^2}\\ensuremath{_3}");
    }
}
