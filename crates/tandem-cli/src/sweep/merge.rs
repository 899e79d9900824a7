//! Writing a sweep folder, and joining shard folders into one (`tandem merge`).
//!
//! A sweep folder holds `runs.csv` (see [`super::run`]), `sweep.json` and the figures.
//! `sweep.json` = `{ "hash", "shard", "runs_in_folder", "columns", "sweep" }`: `sweep` is the
//! resolved sweep (base scenario text with the fixed overrides, every varied field with its
//! distribution, seed, draws, total runs, tandem version), `hash` an FNV-1a hash of it (shards of
//! one sweep share it), `shard` is `{ "index": I, "count": N }` or `null` for a whole sweep.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde_json::{Value as Json, json};

use super::Shard;
use super::run::{Row, csv_text};
use crate::BadInput;
use crate::files;

/// The content of `sweep.json`. `kernels` are the RBF weight-pass kernels the runs used (one
/// for a sweep; the shards' for a merge): recorded as a name, or a list if they differ, outside
/// the hashed sweep (shards on machines with different default kernels still merge).
pub fn sweep_json(
    resolved: &Json,
    hash: &str,
    shard: Option<Shard>,
    header: &[String],
    rows: usize,
    kernels: &[String],
) -> Json {
    json!({
        "hash": hash,
        "shard": shard.map(|s| json!({ "index": s.index, "count": s.count })),
        "runs_in_folder": rows,
        "columns": header,
        "rbf_kernel": match kernels {
            [] => Json::Null,
            [k] => json!(k),
            ks => json!(ks),
        },
        "sweep": resolved,
    })
}

/// Write `runs.csv`, `sweep.json` and (unless `figures` is false) the figures into `dir`
/// (a temporary folder); figure problems come back as warnings.
pub fn write_folder(
    dir: &Path,
    resolved: &Json,
    hash: &str,
    shard: Option<Shard>,
    header: &[String],
    rows: &[Row],
    kernels: &[String],
    figures: bool,
) -> Result<Vec<String>> {
    files::write_text_atomic(&dir.join("runs.csv"), &csv_text(header, rows)?)?;
    files::write_json_atomic(
        &dir.join("sweep.json"),
        &sweep_json(resolved, hash, shard, header, rows.len(), kernels),
    )?;
    let mut problems = Vec::new();
    if figures
        && !rows.is_empty()
        && let Err(e) = super::figures::write(dir, resolved, header, rows)
    {
        problems.push(format!("figures: {e:#}"));
    }
    Ok(problems)
}

/// Largest shard `sweep.json` read, bytes (64 MiB: it holds the base scenario's text, at most
/// 16 MiB, and the varied fields).
pub const MAX_SWEEP_JSON_BYTES: u64 = 64 << 20;

/// Largest shard `runs.csv` read, bytes (1 GiB: about two million runs).
pub const MAX_RUNS_CSV_BYTES: u64 = 1 << 30;

/// A shard folder read back.
struct Part {
    dir: PathBuf,
    meta: Json,
    hash: String,
    shard: Shard,
    header: Vec<String>,
    rows: Vec<Row>,
}

fn read_part(dir: &Path) -> Result<Part> {
    let bad = |why: String| BadInput::msg(format!("cannot merge {}: {why}", dir.display()));
    let sj = dir.join("sweep.json");
    let text = crate::scenario::read_limited(&sj, MAX_SWEEP_JSON_BYTES).map_err(|e| {
        bad(if std::fs::symlink_metadata(&sj).is_ok() {
            format!("cannot read sweep.json: {e}")
        } else {
            format!("no readable sweep.json ({e}); is it a sweep folder?")
        })
    })?;
    let meta: Json = serde_json::from_str(&text)
        .map_err(|e| bad(format!("sweep.json is not valid JSON ({e})")))?;
    let hash = meta
        .get("hash")
        .and_then(Json::as_str)
        .ok_or_else(|| bad("sweep.json has no hash".into()))?
        .to_string();
    // The hash is recomputed from the `sweep` section (as `Sweep::hash` computes it when the
    // shard is written), never trusted: an edited section is another sweep.
    let computed = format!(
        "{:016x}",
        super::fnv1a(
            meta.get("sweep")
                .unwrap_or(&Json::Null)
                .to_string()
                .as_bytes()
        )
    );
    if computed != hash {
        return Err(bad(format!(
            "sweep.json's hash {} does not match its `sweep` section (which hashes to {computed}): \
             the file was edited after the sweep wrote it; refusing to merge",
            crate::scenario::echo(&hash)
        ))
        .into());
    }
    let shard = match meta.get("shard") {
        None | Some(Json::Null) => Shard { index: 0, count: 1 },
        Some(s) => {
            let i = s.get("index").and_then(Json::as_u64);
            let n = s.get("count").and_then(Json::as_u64);
            match (i, n) {
                (Some(i), Some(n)) => {
                    Shard::new(i, n).map_err(|w| bad(format!("sweep.json's shard: {w}")))?
                }
                _ => return Err(bad("sweep.json's shard is not {index, count}".into()).into()),
            }
        }
    };
    let csv_path = dir.join("runs.csv");
    let file = crate::scenario::open_limited(&csv_path, MAX_RUNS_CSV_BYTES)
        .map_err(|e| bad(format!("cannot read runs.csv: {e}")))?;
    let mut rd = csv::Reader::from_reader(file);
    let header: Vec<String> = rd
        .headers()
        .map_err(|e| bad(format!("runs.csv has no header ({e})")))?
        .iter()
        .map(str::to_string)
        .collect();
    let mut rows = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let rec = rec.map_err(|e| bad(format!("runs.csv row {}: {e}", k + 1)))?;
        let index: u64 = rec
            .get(0)
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad(format!("runs.csv row {}: no run index", k + 1)))?;
        if !shard.has(index) {
            return Err(bad(format!(
                "runs.csv has run {index}, which is not in shard {}/{}",
                shard.index, shard.count
            ))
            .into());
        }
        rows.push(Row {
            index,
            cells: rec.iter().map(str::to_string).collect(),
        });
    }
    let n = meta.get("runs_in_folder").and_then(Json::as_u64);
    if n != Some(rows.len() as u64) {
        return Err(bad(format!(
            "runs.csv has {} runs, sweep.json says {} (an incomplete folder?)",
            rows.len(),
            n.map_or("none".to_string(), |n| n.to_string())
        ))
        .into());
    }
    Ok(Part {
        dir: dir.to_path_buf(),
        meta,
        hash,
        shard,
        header,
        rows,
    })
}

/// Which parts of two resolved sweeps differ (for the refusal message).
fn differences(a: &Json, b: &Json) -> Vec<String> {
    let (Some(a), Some(b)) = (a.as_object(), b.as_object()) else {
        return vec!["sweep".into()];
    };
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k) && k.as_str() != "base_scenario")
        .map(|k| match k.as_str() {
            "base_scenario_hash" => "the base scenario".to_string(),
            "vary" => "the varied fields".to_string(),
            other => other.to_string(),
        })
        .collect()
}

/// The merged folder's content: (resolved sweep, hash, header, rows in index order).
pub struct Merged {
    /// The resolved sweep.
    pub resolved: Json,
    /// Its hash.
    pub hash: String,
    /// The table header.
    pub header: Vec<String>,
    /// Every run, in index order.
    pub rows: Vec<Row>,
    /// The RBF kernels the shards recorded, sorted, each once (none for folders written
    /// before `sweep.json` recorded it).
    pub kernels: Vec<String>,
}

/// Read and check shard folders: one sweep (same hash), one shard count, every shard exactly
/// once, every run present.
pub fn merge(dirs: &[PathBuf]) -> Result<Merged> {
    if dirs.is_empty() {
        return Err(BadInput::msg("merge needs at least one shard folder").into());
    }
    let parts: Vec<Part> = dirs.iter().map(|d| read_part(d)).collect::<Result<_>>()?;
    let first = &parts[0];
    for p in &parts[1..] {
        if p.hash != first.hash {
            let diff = differences(&first.meta["sweep"], &p.meta["sweep"]);
            return Err(BadInput::msg(format!(
                "{} is a shard of another sweep than {} (sweep.json hash {} ≠ {}; they differ in {}): \
                 refusing to merge",
                p.dir.display(),
                first.dir.display(),
                p.hash,
                first.hash,
                if diff.is_empty() {
                    "the resolved sweep".to_string()
                } else {
                    diff.join(", ")
                }
            ))
            .into());
        }
        if p.shard.count != first.shard.count {
            return Err(BadInput::msg(format!(
                "{} is shard {}/{} but {} is shard {}/{}: shards of one merge share N",
                p.dir.display(),
                p.shard.index,
                p.shard.count,
                first.dir.display(),
                first.shard.index,
                first.shard.count
            ))
            .into());
        }
        if p.header != first.header {
            return Err(BadInput::msg(format!(
                "{}'s runs.csv has other columns than {}'s",
                p.dir.display(),
                first.dir.display()
            ))
            .into());
        }
    }
    let n = first.shard.count;
    let mut seen: BTreeMap<u64, &Path> = BTreeMap::new();
    for p in &parts {
        if let Some(prev) = seen.insert(p.shard.index, &p.dir) {
            return Err(BadInput::msg(format!(
                "shard {}/{n} is given twice ({} and {})",
                p.shard.index,
                prev.display(),
                p.dir.display()
            ))
            .into());
        }
    }
    // The missing shards, counted without walking 0..N (N is read from a file): the first few
    // named, the rest counted.
    let n_missing = n - seen.len() as u64;
    if n_missing > 0 {
        const SHOWN: usize = 3;
        let mut first_missing = Vec::with_capacity(SHOWN);
        let mut i = 0u64;
        while first_missing.len() < SHOWN && i < n {
            if !seen.contains_key(&i) {
                first_missing.push(format!("{i}/{n}"));
            }
            i += 1;
        }
        let rest = n_missing - first_missing.len() as u64;
        return Err(BadInput::msg(format!(
            "{n_missing} shard{} missing: {}{} (every shard 0/{n} … {}/{n} is needed)",
            if n_missing == 1 { " is" } else { "s are" },
            first_missing.join(", "),
            if rest > 0 {
                format!(", … (and {rest} more)")
            } else {
                String::new()
            },
            n - 1
        ))
        .into());
    }
    let total = first.meta["sweep"]["runs"]
        .as_u64()
        .context("sweep.json has no run count")?;
    let header = first.header.clone();
    let resolved = first.meta["sweep"].clone();
    let hash = first.hash.clone();
    let mut kernels: Vec<String> = Vec::new();
    for p in &parts {
        match &p.meta["rbf_kernel"] {
            Json::String(k) => kernels.push(k.clone()),
            Json::Array(ks) => {
                kernels.extend(ks.iter().filter_map(Json::as_str).map(str::to_string))
            }
            _ => {}
        }
    }
    kernels.sort();
    kernels.dedup();
    let mut rows: Vec<Row> = parts.into_iter().flat_map(|p| p.rows).collect();
    rows.sort_by_key(|r| r.index);
    if rows.len() as u64 != total || rows.iter().enumerate().any(|(i, r)| r.index != i as u64) {
        return Err(BadInput::msg(format!(
            "the shards hold {} runs of {total}: some runs are missing or repeated",
            rows.len()
        ))
        .into());
    }
    Ok(Merged {
        resolved,
        hash,
        header,
        rows,
        kernels,
    })
}
