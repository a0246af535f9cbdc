//! The published result items of the reference works (`data/reference/published-results.toml`):
//! what each published result is, and which study answers it — by published cells (rows of the
//! study's reference file) or by claims. An input, like a study spec: the scoreboard
//! ([`crate::judge::scoreboard`]) classifies the items, and a sequential study may stage the
//! items its cells answer (`[sequential] items`).

use serde::{Deserialize, Serialize};

/// `published-results.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ItemsFile {
    pub item: Vec<Item>,
}

/// One published result item.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Item {
    pub id: String,
    pub seed: String,
    pub source: String,
    pub result: String,
    #[serde(default)]
    pub study: Option<String>,
    #[serde(default)]
    pub cells: Option<CellSelector>,
    #[serde(default)]
    pub claims: Vec<String>,
    /// Claims about the item's shape (an effect's direction), beside `claims` about its levels:
    /// shape confirmed but levels not is TREND, as for published cells.
    #[serde(default)]
    pub shape: Vec<String>,
    #[serde(default)]
    pub missing: Option<String>,
}

/// Which published numbers answer an item (rows of the study's reference file).
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CellSelector {
    pub file: String,
    /// Wide layout: the experiment(s).
    #[serde(default)]
    pub experiment: Option<String>,
    #[serde(default)]
    pub experiments: Vec<String>,
    #[serde(default)]
    pub values: Vec<f64>,
    /// Long layout: the table, stat (`mean` or `max`; both when absent), algorithms and named cells.
    #[serde(default)]
    pub table: Option<String>,
    #[serde(default)]
    pub stat: Option<String>,
    #[serde(default)]
    pub algorithms: Vec<String>,
    #[serde(default)]
    pub cells: Vec<String>,
    #[serde(default)]
    pub maps: Vec<String>,
    pub metrics: Vec<String>,
    /// What the item's effect runs along: `value` (the swept parameter; the wide layout's
    /// default), `cell`, `algorithm` or `map` (series over the others), or `none` (an item about
    /// levels; the long layout's default).
    #[serde(default)]
    pub axis: Option<Axis>,
}

/// The axis a published item's trend runs along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    Value,
    Cell,
    Algorithm,
    Map,
    None,
}

impl Axis {
    /// Fewest cells a series along this axis needs: an ordering needs 3, a comparison 2.
    pub fn min_series(self) -> usize {
        match self {
            Axis::Value | Axis::Cell => 3,
            Axis::Algorithm | Axis::Map => 2,
            Axis::None => usize::MAX,
        }
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Axis::Value => "the swept parameter",
            Axis::Cell => "the cells",
            Axis::Algorithm => "the algorithms",
            Axis::Map => "the maps",
            Axis::None => "none",
        }
    }
}

/// Parses the items file; errors name the item and key.
pub fn parse_items(text: &str) -> Result<Vec<Item>, String> {
    let f: ItemsFile = toml::from_str(text).map_err(|e| e.to_string())?;
    for (i, it) in f.item.iter().enumerate() {
        let answers = it.cells.is_some() as usize
            + (!it.claims.is_empty() || !it.shape.is_empty()) as usize
            + it.missing.is_some() as usize;
        if answers != 1 {
            return Err(format!(
                "item[{i}] ({}): needs exactly one of `cells`, `claims` or `missing`",
                it.id
            ));
        }
        if (it.cells.is_some() || !it.claims.is_empty() || !it.shape.is_empty())
            && it.study.is_none()
        {
            return Err(format!(
                "item[{i}] ({}): `cells` and `claims` need the `study` that answers them",
                it.id
            ));
        }
        if f.item[..i].iter().any(|o| o.id == it.id) {
            return Err(format!("item[{i}]: id `{}` is used twice", it.id));
        }
    }
    Ok(f.item)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_need_one_answer() {
        let ok = "[[item]]\nid = \"A\"\nseed = \"FT\"\nsource = \"L1\"\nresult = \"r\"\nmissing = \"not run\"\n";
        assert_eq!(parse_items(ok).unwrap().len(), 1);
        let two = format!("{ok}claims = [\"x\"]\nstudy = \"s\"\n");
        assert!(parse_items(&two).unwrap_err().contains("exactly one"));
        let no_study = "[[item]]\nid = \"A\"\nseed = \"FT\"\nsource = \"L1\"\nresult = \"r\"\nclaims = [\"x\"]\n";
        assert!(parse_items(no_study).unwrap_err().contains("study"));
        assert!(parse_items(&format!("{ok}{ok}")).unwrap_err().contains("twice"));
    }
}
