//! The configuration the main job ships, applied to the comparison's test
//! images, so that its contact sheets open with what a renderer will run
//! (model, taps and extent as the advice chose them) beside the exact
//! result.

use crate::error::Result;
use crate::filter::disk::{apply_disk, DiskSetup};
use crate::filter::disk_error::view;
use crate::filter::Image;
use crate::filter::Which;
use crate::report::eval::advise::Advice;
use crate::report::eval::disk::first_and_frames;
use crate::report::eval::evaluate::{self, ImageCase};

/// What a contact sheet opens with: a label naming the configuration and
/// its image per case, in the order of the comparison's cases.
#[derive(Clone, Debug)]
pub struct Shipped {
    pub label: String,
    pub images: Vec<Image>,
}

/// The advice's chosen configuration applied to each case: a disk kernel
/// as the user sees it after the frames it records (those advise scored
/// it after, what `apply` runs by default), a separable kernel with the tap
/// table it chose (or its full factors resampled to pixels).
pub fn shipped(advice: &Advice, cases: &[&ImageCase]) -> Result<Shipped> {
    let c = advice.chosen();
    let images = cases
        .iter()
        .map(|case| match &advice.disk_kernel {
            Some(k) => {
                let (first, frames) = first_and_frames(k);
                apply_disk(
                    &case.image,
                    &DiskSetup::new(k, view(case.mm_per_pixel), first, frames),
                )
            }
            None => {
                let which = match c.taps {
                    Some(_) => Which::stored(&advice.kernel),
                    None => Which::Full,
                };
                let passes = evaluate::tap_passes(&advice.kernel, which, case.mm_per_pixel)?;
                Ok(evaluate::filter(case, passes)?.0)
            }
        })
        .collect::<Result<_>>()?;
    Ok(Shipped {
        label: format!("recommended: {}", c.describe()),
        images,
    })
}
