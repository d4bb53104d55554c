//! The main job's stage times: wall and CPU seconds per stage, as
//! report.md's "Stage times" table shows them
//! (`present::ship_report::stage_table`).

/// Wall seconds of the main job's stages, as report.md's "Stage times"
/// shows them: the profile (made or read by the caller), the ground
/// truth, the fits, the comparison's images (exact and filtered), the
/// advice, and writing the files (before the report's last write); the
/// total runs from the profile's start to that write. The stages follow
/// one another; work that waits for none runs beside one and counts in
/// it: the exact images beside the truth, each fit's images as soon as it
/// is fitted (the fits end with the last fit), the engine tables beside
/// the advice, the files beside the preview (the files run on from its
/// end).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    pub profile: f64,
    pub truth: f64,
    pub fits: f64,
    pub images: f64,
    pub advice: f64,
    pub preview: f64,
    pub files: f64,
    /// The engine's fit and files, where asked: wall and CPU seconds.
    pub engine: Option<(f64, f64)>,
    pub total: f64,
    /// CPU seconds of the stages of [`Self::stages`] and of the total,
    /// every thread of the process ([`crate::progress::process_cpu_seconds`]);
    /// the profile's are the process's before the pipeline starts (the
    /// profile and the command's start-up).
    pub cpu: [f64; 8],
}

impl StageTimes {
    /// The stages in order, with their seconds (the engine's where it ran).
    pub fn stages(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("profile", self.profile),
            ("truth", self.truth),
            ("fits", self.fits),
            ("images", self.images),
            ("advice", self.advice),
            ("preview", self.preview),
            ("files", self.files),
        ];
        v.extend(self.engine.map(|(s, _)| ("engine", s)));
        v
    }

    /// CPU seconds in the order of [`Self::stages`], then the total's.
    pub fn cpu_seconds(&self) -> Vec<f64> {
        let mut v = self.cpu[..7].to_vec();
        v.extend(self.engine.map(|(_, c)| c));
        v.push(self.cpu[7]);
        v
    }
}
