//! A map file (`data/maps/<name>.toml`) is a *scenario*: a simulated world ([`Map`]: walls,
//! landmarks, the route driven) or a real dataset ([`DatasetSpec`]: which log to read). This is
//! the one place that knows both, so that `world/` (which simulates) and `dataset/` (which reads
//! logs) need not know each other. Pure: the caller reads the file.

use crate::dataset::DatasetSpec;
use crate::source::{Locator, SourceError};
use crate::world::WorldKind;
use crate::world::map::Map;
use serde::Deserialize;

/// A parsed, validated map file.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The geometry and route (a dataset's file has a name, title and notes, no route).
    pub map: Map,
    /// How to read a real dataset (`None` for a simulated world).
    pub dataset: Option<DatasetSpec>,
}

/// The `[dataset]` table of a map file; the rest of the file is the map's.
#[derive(Deserialize)]
struct DatasetPart {
    dataset: Option<DatasetSpec>,
}

impl Scenario {
    /// Parses and validates a map file's text: the map's keys and the `[dataset]` table, every
    /// problem with its line and key.
    pub fn from_toml(text: &str) -> Result<Scenario, Vec<SourceError>> {
        let loc = Locator::new(text);
        let map = Map::from_toml(text);
        let dataset = toml::from_str::<DatasetPart>(text)
            .map_err(|e| vec![SourceError::from_toml(&loc, &e)])
            .and_then(|part| {
                let errors: Vec<SourceError> = part
                    .dataset
                    .iter()
                    .flat_map(|d| d.validate())
                    .map(|v| SourceError::at_key(&loc, &format!("dataset.{}", v.key), v.message))
                    .collect();
                if errors.is_empty() { Ok(part.dataset) } else { Err(errors) }
            });
        match (map, dataset) {
            (Ok(map), Ok(dataset)) => Ok(Scenario { map, dataset }),
            (Err(mut a), Err(b)) => {
                // a malformed file fails both parsers alike: say it once
                b.into_iter()
                    .filter(|e| !a.contains(e))
                    .collect::<Vec<_>>()
                    .into_iter()
                    .for_each(|e| a.push(e));
                Err(a)
            }
            (Err(e), _) | (_, Err(e)) => Err(e),
        }
    }

    /// Point-landmark world (point landmarks, or a dataset of them) or laser world.
    pub fn world_kind(&self) -> WorldKind {
        match &self.dataset {
            Some(d) => d.world_kind(),
            None => self.map.world_kind(),
        }
    }
}
