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
            '⇔' => out.push_str("\\ensuremath{\\Leftrightarrow}"),
            '⇒' => out.push_str("\\ensuremath{\\Rightarrow}"),
            '↔' => out.push_str("\\ensuremath{\\leftrightarrow}"),
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

/// Text width of a study document [pt]: A4 (597.5 pt) less two 2 cm margins.
pub const TEXT_WIDTH_PT: f64 = 484.0;
/// Average width of a table character [em]: Latin Modern's digits are 0.5 em, and a table's
/// signs, brackets and capitals push its longest entries a little wider.
const CHAR_EM: f64 = 0.56;
/// Column separation in the study documents' tables [pt] (each side).
pub const TABCOLSEP_PT: f64 = 3.0;

/// A column spec of a `tabular` preamble, split: `l`, `r`, `c` or `p{…}`.
fn column_specs(align: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut chars = align.chars().peekable();
    while let Some(c) = chars.next() {
        if c == 'p' || c == 'm' || c == 'b' {
            let mut spec = String::from(c);
            let mut depth = 0;
            for d in chars.by_ref() {
                spec.push(d);
                match d {
                    '{' => depth += 1,
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    _ => {}
                }
            }
            out.push(spec);
        } else if !c.is_whitespace() && c != '@' {
            out.push(c.to_string());
        }
    }
    out
}

/// Estimated width [pt] of a column at `font_pt`: a `p{x\linewidth}` column its given width, any
/// other its longest entry at [`CHAR_EM`] per character, plus the column separation.
fn column_width(spec: &str, entries: impl Iterator<Item = usize>, font_pt: f64) -> f64 {
    if let Some(x) = spec.strip_prefix("p{").and_then(|s| s.strip_suffix("\\linewidth}")) {
        return x.parse::<f64>().unwrap_or(0.3) * TEXT_WIDTH_PT + 2.0 * TABCOLSEP_PT;
    }
    entries.max().unwrap_or(0) as f64 * CHAR_EM * font_pt + 2.0 * TABCOLSEP_PT
}

/// A table split by columns into parts that each fit the text width at `font_pt`, every part
/// repeating the first `labels` columns. A part whose label columns alone leave no room wraps the
/// widest label column (`p{…}`) instead. One part when the table fits.
pub fn parts(
    table: &super::model::TableView,
    labels: usize,
    font_pt: f64,
) -> Vec<super::model::TableView> {
    let specs = column_specs(&table.align);
    let n = table.columns.len();
    if specs.len() != n || n == 0 {
        return vec![table.clone()];
    }
    let chars = |k: usize| {
        std::iter::once(table.columns[k].chars().count())
            .chain(table.rows.iter().filter_map(move |r| r.get(k)).map(|v| v.chars().count()))
    };
    let widths: Vec<f64> = (0..n).map(|k| column_width(&specs[k], chars(k), font_pt)).collect();
    let labels = labels.min(n);
    let label_width: f64 = widths[..labels].iter().sum();
    // greedy: as many data columns per part as fit
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut used = label_width;
    for k in labels..n {
        if groups.is_empty() || used + widths[k] > TEXT_WIDTH_PT {
            groups.push(Vec::new());
            used = label_width;
        }
        groups.last_mut().expect("pushed").push(k);
        used += widths[k];
    }
    if groups.is_empty() {
        groups.push(Vec::new());
    }
    groups
        .into_iter()
        .map(|data| {
            let keep: Vec<usize> = (0..labels).chain(data.iter().copied()).collect();
            let mut part_specs: Vec<String> = keep.iter().map(|&k| specs[k].clone()).collect();
            let total: f64 = keep.iter().map(|&k| widths[k]).sum();
            if total > TEXT_WIDTH_PT && labels > 0 {
                // wrap the widest label column into the room that is left
                let (wi, _) = (0..labels)
                    .map(|i| (i, widths[i]))
                    .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
                let room = (TEXT_WIDTH_PT - (total - widths[wi]) - 2.0 * TABCOLSEP_PT)
                    .max(0.12 * TEXT_WIDTH_PT);
                part_specs[wi] = format!("p{{{:.2}\\linewidth}}", room / TEXT_WIDTH_PT);
            }
            super::model::TableView {
                columns: keep.iter().map(|&k| table.columns[k].clone()).collect(),
                rows: table
                    .rows
                    .iter()
                    .map(|r| keep.iter().map(|&k| r.get(k).cloned().unwrap_or_default()).collect())
                    .collect(),
                align: part_specs.concat(),
            }
        })
        .collect()
}

#[cfg(test)]
mod parts_tests {
    use super::*;
    use crate::report::model::TableView;

    fn table(columns: usize, width: usize) -> TableView {
        TableView {
            columns: (0..columns).map(|k| format!("c{k}")).collect(),
            rows: vec![
                (0..columns)
                    .map(|k| if k == 0 { "label".to_string() } else { "9".repeat(width) })
                    .collect(),
            ],
            align: format!("l{}", "r".repeat(columns - 1)),
        }
    }

    #[test]
    fn a_table_that_fits_is_one_part_and_a_wide_one_is_split_with_its_labels_repeated() {
        let t = table(4, 10);
        assert_eq!(parts(&t, 1, 7.0), vec![t]);
        // 12 data columns of 30 digits at 7 pt: 124 pt each, three per part
        let wide = table(13, 30);
        let p = parts(&wide, 1, 7.0);
        assert_eq!(p.len(), 4);
        for part in &p {
            assert_eq!(part.columns[0], "c0");
            assert_eq!(part.rows[0][0], "label");
            assert_eq!(part.align.len(), part.columns.len());
            let width: f64 = part.columns.len() as f64 * 2.0 * TABCOLSEP_PT
                + (part.columns.len() - 1) as f64 * 30.0 * CHAR_EM * 7.0;
            assert!(width <= TEXT_WIDTH_PT, "{width}");
        }
        // every data column exactly once, in order
        let cols: Vec<String> = p.iter().flat_map(|t| t.columns[1..].to_vec()).collect();
        assert_eq!(cols, wide.columns[1..].to_vec());
    }

    #[test]
    fn labels_too_wide_for_one_column_wrap() {
        let mut t = table(2, 10);
        t.rows[0][0] = "x".repeat(300);
        let p = parts(&t, 1, 7.0);
        assert_eq!(p.len(), 1);
        assert!(
            p[0].align.starts_with("p{0.") && p[0].align.ends_with("\\linewidth}r"),
            "{}",
            p[0].align
        );
        // p{} columns are read back as their width
        assert_eq!(column_specs("lp{0.3\\linewidth}r"), vec!["l", "p{0.3\\linewidth}", "r"]);
    }
}
