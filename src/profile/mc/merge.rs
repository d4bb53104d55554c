//! Shards: what a partial run records, and the merge that verifies each
//! shard and rebuilds the single run exactly.

use super::*;

/// What a shard keeps so that `merge_shards` rebuilds the single run exactly.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(super) struct ShardRecord {
    pub(super) k: u64,
    pub(super) n: u64,
    pub(super) chunks: (u64, u64),
    pub(super) config: McConfig,
    pub(super) options: McOptions,
    pub(super) grid_rule: serde_json::Value,
    pub(super) tallies: Vec<ExactTally>,
    /// SHA-256 of everything above with the material and the bin edges
    /// (`content_hash`): a shard changed after it was written is refused.
    #[serde(default)]
    pub(super) sha256: String,
}

impl ShardRecord {
    /// The SHA-256 (hex) of the record's JSON without its hash, the
    /// material and the bin edges: a function of the values only (the
    /// exact sums serialise canonically, floats round-trip exactly).
    pub(super) fn content_hash(&self, material: &Material, edges: &[f64]) -> Result<String> {
        use sha2::Digest;
        let bytes = serde_json::to_vec(&(
            self.k,
            self.n,
            self.chunks,
            &self.config,
            &self.options,
            &self.grid_rule,
            &self.tallies,
            material,
            edges,
        ))
        .map_err(|e| Error::Unsupported(format!("cannot hash the shard: {e}")))?;
        Ok(sha2::Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect())
    }
}

/// Tolerance of the energy balance of a merged or shard tally, per photon
/// (scaled by the roulette's gains and losses, which cancel): the exact
/// sums close it to the rounding of each chunk's f64 sums.
pub const MERGE_BALANCE_TOLERANCE: f64 = 1e-9;

/// Combines shards of one run (profiles written with `McOptions::shard`,
/// named for errors) into the profile of the single run: bit-identical to it
/// except `elapsed_s`, which is the sum of the shards'. Refuses parts of
/// different runs, duplicates, an incomplete set, and shards that fail the
/// checks of [`ShardMerger::add`].
pub fn merge_shards(parts: &[(String, Profile)]) -> Result<Profile> {
    let mut m = ShardMerger::new();
    for (name, p) in parts {
        m.add(name, p.clone())?;
    }
    m.finish()
}

/// Merges shards one at a time (a merge holds one shard and the running
/// sums, never all the shards).
#[derive(Default)]
pub struct ShardMerger {
    /// The first shard (its `extra.shard` dropped), its name and record
    /// (its tallies moved into `tallies`).
    pub(super) first: Option<(String, Profile, ShardRecord)>,
    pub(super) tallies: Vec<ExactTally>,
    pub(super) seen: std::collections::BTreeMap<u64, String>,
    pub(super) elapsed: f64,
}

impl ShardMerger {
    pub fn new() -> ShardMerger {
        ShardMerger::default()
    }

    /// Adds one shard, named `name` in errors. Refused, naming the shard and
    /// the field: a profile without a shard record; a record whose content
    /// hash does not match (changed after it was written); a shard of
    /// another run (material, channels, seed, grid, photons, settings) or
    /// one given twice; tallies whose layout, photons or chunks do not fit
    /// the shard, whose energy balance does not close or whose sums of
    /// squares are below their sums squared ([`ExactTally::verify`]); sums
    /// that would overflow.
    pub fn add(&mut self, name: &str, mut p: Profile) -> Result<()> {
        let v = p.extra.get("shard").ok_or_else(|| {
            Error::format(
                name,
                "not a shard: no extra.shard (a complete profile, or not from the Monte Carlo simulator)",
            )
        })?;
        let mut r = ShardRecord::deserialize(v)
            .map_err(|e| Error::format(name, format!("malformed extra.shard: {e}")))?;
        p.extra["shard"] = serde_json::Value::Null;
        if r.sha256.is_empty() {
            return Err(Error::format(
                name,
                "extra.shard.sha256 is missing: the shard cannot be checked (written by an older \
                 ssskit, or edited); trace it again",
            ));
        }
        if r.content_hash(&p.material, &p.r_edges)? != r.sha256 {
            return Err(Error::format(
                name,
                "extra.shard.sha256 does not match the shard's content: its tallies, settings, \
                 material or grid were changed after it was written",
            ));
        }
        if let Some((name0, p0, r0)) = &self.first {
            check_same_run(name, &p, &r, name0, p0, r0)?;
        }
        let n = r.n;
        let cap = r.config.budget.max_photons();
        let chunks = cap.div_ceil(CHUNK);
        let nb = p.r_edges.len().saturating_sub(1);
        let single = r.options.single_scatter;
        if !matches!(r.config.budget, PhotonBudget::Fixed(_))
            || r.k == 0
            || r.k > n
            || n > chunks
            || (Shard { k: r.k, n }).chunks(chunks) != r.chunks
        {
            return Err(Error::format(
                name,
                format!(
                    "extra.shard: part {}/{} with chunks {:?} does not fit a run of {cap} photons",
                    r.k, n, r.chunks
                ),
            ));
        }
        if let Some(other) = self.seen.get(&r.k) {
            return Err(Error::Unsupported(format!(
                "shard {}/{n} given twice ({other} and {name}): shards must not overlap",
                r.k
            )));
        }
        let want = (r.chunks.1 * CHUNK).min(cap) - r.chunks.0 * CHUNK;
        if r.tallies.len() != r.config.channels.len()
            || r.tallies
                .iter()
                .any(|t| !t.has_layout(nb, single) || t.photons != want)
        {
            return Err(Error::format(
                name,
                "extra.shard: tallies do not match the channels, grid or photons of the shard",
            ));
        }
        for (t, ch) in r.tallies.iter().zip(&r.config.channels) {
            t.verify(MERGE_BALANCE_TOLERANCE).map_err(|e| {
                Error::format(name, format!("extra.shard.tallies[{}]: {e}", ch.name()))
            })?;
        }
        let tallies = std::mem::take(&mut r.tallies);
        if self.tallies.is_empty() {
            self.tallies = (0..tallies.len())
                .map(|_| ExactTally::new(nb, single))
                .collect();
        }
        for ((a, t), ch) in self
            .tallies
            .iter_mut()
            .zip(&tallies)
            .zip(&r.config.channels)
        {
            a.add(t).map_err(|e| {
                Error::format(name, format!("extra.shard.tallies[{}]: {e}", ch.name()))
            })?;
        }
        self.seen.insert(r.k, name.to_string());
        self.elapsed += p.elapsed_s;
        if self.first.is_none() {
            self.first = Some((name.to_string(), p, r));
        }
        Ok(())
    }

    /// The profile of the single run, once every shard was added.
    pub fn finish(self) -> Result<Profile> {
        let Some((name0, p0, r0)) = self.first else {
            return Err(Error::Unsupported("no shards to merge".into()));
        };
        let n = r0.n;
        if self.seen.len() as u64 != n {
            let missing: Vec<String> = (1..=n)
                .filter(|k| !self.seen.contains_key(k))
                .take(10)
                .map(|k| match part_name(&name0, r0.k, k) {
                    Some(file) => format!("{k} ({file})"),
                    None => k.to_string(),
                })
                .collect();
            return Err(Error::Unsupported(format!(
                "missing shard(s) {}{} of {n}: a merge needs all {n} parts of the run",
                missing.join(", "),
                if (n - self.seen.len() as u64) > 10 {
                    ", ..."
                } else {
                    ""
                }
            )));
        }
        for (t, ch) in self.tallies.iter().zip(&r0.config.channels) {
            t.verify(MERGE_BALANCE_TOLERANCE).map_err(|e| {
                Error::Unsupported(format!("the merged tally of channel {}: {e}", ch.name()))
            })?;
        }
        let grid = RadialGrid {
            edges: p0.r_edges.clone(),
        };
        let (status, _) = statuses(&p0.material, &r0.config.channels, &grid, &self.tallies);
        let runs: Vec<ChannelRun> = self
            .tallies
            .into_iter()
            .zip(status)
            .map(|(tally, status)| ChannelRun {
                tally,
                status,
                converged: true,
                work_capped: false,
                by_floor: false,
            })
            .collect();
        let mut p = build_profile(
            &p0.material,
            &r0.config,
            &r0.options,
            &grid,
            r0.grid_rule.clone(),
            &runs,
            self.elapsed,
        );
        // Anything the caller added to the parts' parameters (e.g. the .mci
        // origin) is kept, as in the single run.
        p.source.params = shard_params(&p0);
        Ok(p)
    }
}

/// The name the part of shard `k` would have, when the name of the part of
/// shard `k0` holds `k0` as its one free-standing number (`part-7.json`,
/// `out/7/p.json`): a missing shard is then named as the file the recipe
/// expected, not only by number.
pub(super) fn part_name(name0: &str, k0: u64, k: u64) -> Option<String> {
    let digits = k0.to_string();
    let b = name0.as_bytes();
    let mut found = None;
    for (i, _) in name0.match_indices(&digits) {
        let j = i + digits.len();
        let free =
            (i == 0 || !b[i - 1].is_ascii_digit()) && (j == b.len() || !b[j].is_ascii_digit());
        if free {
            if found.is_some() {
                return None;
            }
            found = Some(i);
        }
    }
    found.map(|i| format!("{}{k}{}", &name0[..i], &name0[i + digits.len()..]))
}

/// A shard's `source.params` without its part number.
pub(super) fn shard_params(p: &Profile) -> serde_json::Value {
    let mut q = p.source.params.clone();
    if let Some(o) = q.as_object_mut() {
        o.remove("shard");
    }
    q
}

/// Refuses shard `name` unless it is of the run of the first shard `name0`.
pub(super) fn check_same_run(
    name: &str,
    p: &Profile,
    r: &ShardRecord,
    name0: &str,
    p0: &Profile,
    r0: &ShardRecord,
) -> Result<()> {
    let differ = |what: String| {
        Err(Error::Unsupported(format!(
            "cannot merge {name} with {name0}: {what}"
        )))
    };
    let settings = |r: &ShardRecord| {
        serde_json::to_value((&r.config.channels, &r.options, &r.grid_rule)).unwrap_or_default()
    };
    if p.material != p0.material {
        return differ(format!(
            "different materials ('{}' vs '{}', or the same name with other coefficients)",
            p.material.name, p0.material.name
        ));
    }
    if p.channels != p0.channels || r.config.channels != r0.config.channels {
        return differ("different channels".into());
    }
    if p.source.seed != p0.source.seed || r.config.seed != r0.config.seed {
        return differ(format!(
            "different seeds ({} vs {})",
            r.config.seed, r0.config.seed
        ));
    }
    if p.r_edges != p0.r_edges {
        return differ("different radial grids".into());
    }
    if r.config.budget != r0.config.budget {
        return differ(format!(
            "different photon totals ({} vs {} per channel)",
            r.config.budget.max_photons(),
            r0.config.budget.max_photons()
        ));
    }
    if r.n != r0.n {
        return differ(format!(
            "split into different numbers of shards ({} vs {})",
            r.n, r0.n
        ));
    }
    let (params, params0) = (shard_params(p), shard_params(p0));
    if params != params0 || settings(r) != settings(r0) {
        let keys: Vec<String> = params0
            .as_object()
            .map(|o| {
                o.iter()
                    .filter(|(k, v)| params.get(k.as_str()) != Some(v))
                    .map(|(k, _)| k.clone())
                    .collect()
            })
            .unwrap_or_default();
        return differ(format!(
            "different simulation settings (source.params: {})",
            keys.join(", ")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::part_name;

    #[test]
    fn a_missing_part_is_named_after_the_others() {
        assert_eq!(
            part_name("part-1.json", 1, 3).as_deref(),
            Some("part-3.json")
        );
        assert_eq!(
            part_name("out/12/p.json", 12, 7).as_deref(),
            Some("out/7/p.json")
        );
        // 1 inside 11 or 21 is not the shard number; two free-standing 1s
        // leave the pattern ambiguous.
        assert_eq!(
            part_name("run11-1.json", 1, 2).as_deref(),
            Some("run11-2.json")
        );
        assert_eq!(part_name("1-part-1.json", 1, 2), None);
        assert_eq!(part_name("part.json", 1, 2), None);
    }
}
