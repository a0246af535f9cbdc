//! Cause texts that cannot drift. A claim's `cause` explains a verdict with numbers; each number
//! is either
//! - a **result**, written as a placeholder the report fills from the study's runs:
//!   `{STAT:METRIC:MAP:CELL}` with STAT one of `mean`, `sd`, `median`, `min`, `max`, `lo` / `hi`
//!   (the 95 % CI of the mean), `n`; or `{STAT:METRIC:MAP:CELL/CELL}` with STAT `ratio` or `diff`
//!   (of the two cells' means), or `pdiff`, `pdlo`, `pdhi` (the mean paired difference over the
//!   replicates and its 95 % CI). CELL is a sweep point's label, optionally `@algorithm` (default:
//!   the claim's algorithm); `STAT.k` gives k significant digits (default 3);
//! - a **published** number, inside a citation that starts with the work's tag: `[FT Table 10.6:
//!   14.2 and 91.2]`, `[EP L423]`;
//! - or a **setting** of the runs, in a code span: `` `Lmin = 7 m` ``.
//!
//! [`literal_numbers`] finds any other number, which `slamlab validate` rejects. Numbers inside
//! words (`bigloop2`, `C6`) are names, not numbers.

/// What a placeholder computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stat {
    Mean,
    Sd,
    Median,
    Min,
    Max,
    Lo,
    Hi,
    N,
    Ratio,
    Diff,
    PairedDiff,
    PairedLo,
    PairedHi,
}

impl Stat {
    fn parse(s: &str) -> Option<Stat> {
        Some(match s {
            "mean" => Stat::Mean,
            "sd" => Stat::Sd,
            "median" => Stat::Median,
            "min" => Stat::Min,
            "max" => Stat::Max,
            "lo" => Stat::Lo,
            "hi" => Stat::Hi,
            "n" => Stat::N,
            "ratio" => Stat::Ratio,
            "diff" => Stat::Diff,
            "pdiff" => Stat::PairedDiff,
            "pdlo" => Stat::PairedLo,
            "pdhi" => Stat::PairedHi,
            _ => return None,
        })
    }
    /// Whether it compares two cells.
    pub fn pairs(self) -> bool {
        matches!(
            self,
            Stat::Ratio | Stat::Diff | Stat::PairedDiff | Stat::PairedLo | Stat::PairedHi
        )
    }
}

/// A sweep point, with the algorithm if not the claim's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cell {
    pub point: String,
    pub algorithm: Option<String>,
}

/// One `{…}` of a cause.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Placeholder {
    pub stat: Stat,
    pub digits: usize,
    pub metric: String,
    pub map: String,
    /// One cell, or two for the comparing stats.
    pub cells: Vec<Cell>,
    /// The placeholder as written, for error messages.
    pub source: String,
}

/// A cause, parsed: text and placeholders in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    Text(String),
    Value(Placeholder),
}

fn cell(s: &str) -> Cell {
    match s.split_once('@') {
        Some((p, a)) => Cell { point: p.to_string(), algorithm: Some(a.to_string()) },
        None => Cell { point: s.to_string(), algorithm: None },
    }
}

fn placeholder(inner: &str) -> Result<Placeholder, String> {
    let source = format!("{{{inner}}}");
    let parts: Vec<&str> = inner.split(':').collect();
    let [stat, metric, map, cells] = parts[..] else {
        return Err(format!("{source}: expected {{STAT:METRIC:MAP:CELL}}"));
    };
    let (stat, digits) = match stat.split_once('.') {
        Some((s, d)) => {
            (s, d.parse::<usize>().map_err(|_| format!("{source}: `{d}` is not a digit count"))?)
        }
        None => (stat, 3),
    };
    let stat = Stat::parse(stat).ok_or_else(|| {
        format!(
            "{source}: unknown statistic `{stat}` (mean, sd, median, min, max, lo, hi, n, ratio, diff, pdiff, pdlo, pdhi)"
        )
    })?;
    let cells: Vec<Cell> = cells.split('/').map(cell).collect();
    if cells.len() != if stat.pairs() { 2 } else { 1 } {
        return Err(format!(
            "{source}: `{}` takes {}",
            inner.split(':').next().unwrap_or(""),
            if stat.pairs() { "two cells, A/B" } else { "one cell" }
        ));
    }
    if metric.is_empty() || map.is_empty() || cells.iter().any(|c| c.point.is_empty()) {
        return Err(format!("{source}: empty metric, map or cell"));
    }
    Ok(Placeholder {
        stat,
        digits: digits.clamp(1, 6),
        metric: metric.to_string(),
        map: map.to_string(),
        cells,
        source,
    })
}

/// Splits a cause into text and placeholders.
pub fn parse(text: &str) -> Result<Vec<Piece>, String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(start) = rest.find('{') {
        if start > 0 {
            out.push(Piece::Text(rest[..start].to_string()));
        }
        let end = rest[start..].find('}').ok_or_else(|| {
            format!("a `{{` without its `}}`: {}", &rest[start..rest.len().min(start + 40)])
        })?;
        out.push(Piece::Value(placeholder(&rest[start + 1..start + end])?));
        rest = &rest[start + end + 1..];
    }
    if !rest.is_empty() {
        out.push(Piece::Text(rest.to_string()));
    }
    Ok(out)
}

/// The text with placeholders, citations (`[TAG …]`) and code spans removed.
fn bare(text: &str) -> String {
    let mut out = String::new();
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let close = |open: usize, ch: char| chars[open + 1..].iter().position(|x| *x == ch);
        // the span this character opens, if any: a placeholder, a code span, or a citation (`[`
        // then an uppercase tag such as FT or EP, then a space, `]` or `:`)
        let closer = match c {
            '{' => Some('}'),
            '`' => Some('`'),
            '[' if chars.get(i + 1).is_some_and(|x| x.is_ascii_uppercase()) => {
                let tag_end = chars[i + 1..]
                    .iter()
                    .position(|x| !(x.is_ascii_uppercase() || x.is_ascii_digit()))
                    .map(|k| i + 1 + k);
                tag_end
                    .is_some_and(|e| e - i >= 3 && matches!(chars[e], ' ' | ']' | ':'))
                    .then_some(']')
            }
            _ => None,
        };
        if let Some(k) = closer.and_then(|ch| close(i, ch)) {
            i += k + 2;
            out.push(' ');
            continue;
        }
        out.push(c);
        i += 1;
    }
    out
}

/// The literal numbers of a cause: digits that are not inside a placeholder, a citation or a code
/// span, and not part of a word (`bigloop2`, `C6`, `L7410`).
pub fn literal_numbers(text: &str) -> Vec<String> {
    let b: Vec<char> = bare(text).chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let in_word = i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_');
            let mut j = i;
            while j < b.len()
                && (b[j].is_ascii_digit()
                    || (matches!(b[j], '.' | ',')
                        && b.get(j + 1).is_some_and(|c| c.is_ascii_digit())))
            {
                j += 1;
            }
            let in_word = in_word || b.get(j).is_some_and(|c| c.is_alphabetic() && *c != 'x');
            if !in_word {
                out.push(b[i..j].iter().collect());
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_parse() {
        let p =
            parse("ours {mean:landmarks_detected:recinto_basico:features.lmin_m=5} of 8").unwrap();
        assert_eq!(p.len(), 3);
        let Piece::Value(v) = &p[1] else { panic!() };
        assert_eq!(v.stat, Stat::Mean);
        assert_eq!(v.cells[0].point, "features.lmin_m=5");
        let p = parse("{ratio.2:f_mean:ep_polygon:odo10@crs2/odo10@epsm}").unwrap();
        let Piece::Value(v) = &p[0] else { panic!() };
        assert_eq!(v.digits, 2);
        assert_eq!(v.cells[1].algorithm.as_deref(), Some("epsm"));
        assert!(parse("{mean:x:y}").unwrap_err().contains("expected"));
        assert!(parse("{avg:x:y:z}").unwrap_err().contains("unknown statistic"));
        assert!(parse("{ratio:x:y:z}").unwrap_err().contains("two cells"));
        assert!(parse("open {mean:x").unwrap_err().contains("without"));
    }

    #[test]
    fn literal_numbers_are_found_outside_placeholders_citations_and_settings() {
        let ok = "Recinto keeps {mean:landmarks_detected:recinto_basico:base} landmarks at `Lmin = 7 m` [FT Table 10.4: 4.4], on bigloop2 and in C6 (see [EP] L423)";
        assert!(literal_numbers(ok).is_empty(), "{:?}", literal_numbers(ok));
        assert_eq!(
            literal_numbers("error 0.23 against 0.14 m over 22 landmarks"),
            ["0.23", "0.14", "22"]
        );
        // a bracket that is not a citation does not hide numbers
        assert_eq!(literal_numbers("CI [0.02, 0.15]"), ["0.02", "0.15"]);
        // a number glued to a unit is still a number; a ratio sign is not a word
        assert_eq!(literal_numbers("57× in 3 s, 2D"), ["57", "3"]);
    }
}
