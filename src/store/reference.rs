//! Published reference results (`data/reference/*.csv`, format in data/reference/README.md):
//! text → rows. Key columns `experiment, table, map, parameter, value`; a column named after a
//! slamlab metric holds the published mean, `<metric>_var` its published variance; other
//! columns document provenance.
//!
//! A second, long layout holds per-cell tables such as [EP]'s (`epsm-tables.csv`): key columns
//! `table, map, algorithm, cell, stat, metric, value`, one published number per line. Its rows
//! become [`ReferenceRow`]s with `experiment` = `table`, the named cell in `cell`, and the
//! number under slamlab's metric name ([`cell_metric_name`]).

use crate::metrics::metric_def;

/// One published cell.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceRow {
    pub experiment: String,
    pub table: String,
    pub map: String,
    pub parameter: String,
    pub value: f64,
    /// (metric or `<metric>_var`, value), in column order.
    pub metrics: Vec<(String, f64)>,
    /// Long layout only: the algorithm and the named cell (sweep label) of the number.
    pub algorithm: String,
    pub cell: String,
}

impl ReferenceRow {
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }
}

const KEYS: [&str; 5] = ["experiment", "table", "map", "parameter", "value"];

fn number(field: &str) -> Option<f64> {
    match field {
        "inf" => Some(f64::INFINITY),
        f => f.parse().ok(),
    }
}

/// slamlab's metric name for a long-layout (metric, stat): `ax_mm` + `mean` → `ax_mean_mm`,
/// `f` + `max` → `f_max` (the unit stays last).
pub fn cell_metric_name(metric: &str, stat: &str) -> String {
    match metric.rsplit_once('_') {
        Some((base, unit)) => format!("{base}_{stat}_{unit}"),
        None => format!("{metric}_{stat}"),
    }
}

const CELL_KEYS: [&str; 7] = ["table", "map", "algorithm", "cell", "stat", "metric", "value"];

/// Parses the long (per-cell) layout.
fn parse_cells(text: &str) -> Result<Vec<ReferenceRow>, String> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or("the file is empty")?;
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let keys: Vec<usize> = CELL_KEYS
        .iter()
        .map(|k| {
            columns
                .iter()
                .position(|c| c == k)
                .ok_or_else(|| format!("line 1: missing column `{k}`"))
        })
        .collect::<Result<_, _>>()?;
    let mut rows = Vec::new();
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(format!(
                "line {}: {} fields, the header has {}",
                n + 1,
                fields.len(),
                columns.len()
            ));
        }
        let value = number(fields[keys[6]]).ok_or_else(|| {
            format!("line {}: column `value` is not a number: {:?}", n + 1, fields[keys[6]])
        })?;
        rows.push(ReferenceRow {
            experiment: fields[keys[0]].to_string(),
            table: fields[keys[0]].to_string(),
            map: fields[keys[1]].to_string(),
            parameter: String::new(),
            value: f64::NAN,
            metrics: vec![(cell_metric_name(fields[keys[5]], fields[keys[4]]), value)],
            algorithm: fields[keys[2]].to_string(),
            cell: fields[keys[3]].to_string(),
        });
    }
    Ok(rows)
}

/// Parses a reference file (either layout); errors name the line (1-based) and column.
pub fn parse(text: &str) -> Result<Vec<ReferenceRow>, String> {
    if text.lines().next().is_some_and(|h| h.split(',').any(|c| c.trim() == "cell")) {
        return parse_cells(text);
    }
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or("the file is empty")?;
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let index = |name: &str| {
        columns
            .iter()
            .position(|c| *c == name)
            .ok_or_else(|| format!("line 1: missing column `{name}`"))
    };
    let keys: Vec<usize> = KEYS.iter().map(|k| index(k)).collect::<Result<_, _>>()?;
    let metric_columns: Vec<(usize, &str)> = columns
        .iter()
        .enumerate()
        .filter(|(_, c)| {
            metric_def(c).is_some()
                || c.strip_suffix("_var").is_some_and(|m| metric_def(m).is_some())
        })
        .map(|(i, c)| (i, *c))
        .collect();
    let mut rows = Vec::new();
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(format!(
                "line {}: {} fields, the header has {}",
                n + 1,
                fields.len(),
                columns.len()
            ));
        }
        let value = number(fields[keys[4]]).ok_or_else(|| {
            format!("line {}: column `value` is not a number: {:?}", n + 1, fields[keys[4]])
        })?;
        let metrics = metric_columns
            .iter()
            .map(|&(i, name)| {
                number(fields[i]).map(|v| (name.to_string(), v)).ok_or_else(|| {
                    format!("line {}: column `{name}` is not a number: {:?}", n + 1, fields[i])
                })
            })
            .collect::<Result<_, _>>()?;
        rows.push(ReferenceRow {
            experiment: fields[keys[0]].to_string(),
            table: fields[keys[1]].to_string(),
            map: fields[keys[2]].to_string(),
            parameter: fields[keys[3]].to_string(),
            value,
            metrics,
            algorithm: String::new(),
            cell: String::new(),
        });
    }
    Ok(rows)
}

/// The header and the lines of the given experiments, verbatim (what a study's results keep).
pub fn select(text: &str, experiments: &[String]) -> String {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    // The long layout's experiments are its tables.
    let at = header
        .split(',')
        .position(|c| c.trim() == "experiment")
        .or_else(|| header.split(',').position(|c| c.trim() == "table"))
        .unwrap_or(0);
    let mut out = format!("{header}\n");
    for l in lines.filter(|l| {
        l.split(',').nth(at).map(str::trim).is_some_and(|e| experiments.iter().any(|x| x == e))
    }) {
        out.push_str(l);
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "experiment,table,map,parameter,value,landmark_error_m,landmark_error_m_var,landmarks_detected,source_lines\n\
        dmax,10.2,bigloop2,features.dmax_m,0.001,0.12,0.0015,13.0,L1-2\n\
        lmin,10.4,bigloop,features.lmin_m,10,inf,0,0,L3-4\n";

    #[test]
    fn parses_metrics_variances_and_infinity() {
        let rows = parse(TEXT).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].metric("landmark_error_m"), Some(0.12));
        assert_eq!(rows[0].metric("landmark_error_m_var"), Some(0.0015));
        assert_eq!(rows[1].metric("landmark_error_m"), Some(f64::INFINITY));
        assert_eq!(rows[1].value, 10.0);
        assert!(rows[0].metric("source_lines").is_none());
    }

    #[test]
    fn bad_fields_name_their_line() {
        let bad = TEXT.replace("0.0015", "lots");
        assert_eq!(
            parse(&bad).unwrap_err(),
            "line 2: column `landmark_error_m_var` is not a number: \"lots\""
        );
        assert!(parse(&TEXT.replace(",L3-4", "")).unwrap_err().starts_with("line 3:"));
    }

    #[test]
    fn select_keeps_one_experiment_verbatim() {
        let s = select(TEXT, &["lmin".to_string()]);
        assert_eq!(s.lines().count(), 2);
        assert!(s.ends_with("lmin,10.4,bigloop,features.lmin_m,10,inf,0,0,L3-4\n"));
    }

    #[test]
    fn long_layout_names_metrics_and_cells() {
        let text = "table,map,algorithm,cell,stat,metric,value,source_lines\n2,ep_rect_column,epsm,odo10,mean,ax_mm,2.8446,L376\n2,ep_rect_column,epsm,odo10,max,f,54.265,L376\n5,ep_bigmap,crs2,none,mean,ax_mm,3.40E-06,L530\n";
        let rows = parse(text).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!((rows[0].algorithm.as_str(), rows[0].cell.as_str()), ("epsm", "odo10"));
        assert_eq!(rows[0].metric("ax_mean_mm"), Some(2.8446));
        assert_eq!(rows[1].metric("f_max"), Some(54.265));
        assert_eq!(rows[2].metric("ax_mean_mm"), Some(3.4e-6));
        assert_eq!(select(text, &["5".to_string()]).lines().count(), 2);
        assert!(parse(&text.replace("54.265", "x")).unwrap_err().starts_with("line 3:"));
        assert_eq!(cell_metric_name("atheta_deg", "max"), "atheta_max_deg");
        assert_eq!(cell_metric_name("evals", "mean"), "evals_mean");
    }

    #[test]
    fn the_thesis_tables_parse() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/reference/fastslam-thesis.csv"
        ))
        .unwrap();
        let rows = parse(&text).unwrap();
        assert_eq!(rows.len(), 183);
        assert!(
            rows.iter().all(|r| r.metric("landmark_error_m").is_some()
                && r.metric("landmarks_detected").is_some())
        );
    }
}
