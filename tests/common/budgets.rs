//! Photon budgets and the Monte Carlo configurations built on them that
//! several tests run: each spelled once.

use ssskit::material::Channel;
use ssskit::profile::mc::{McConfig, PhotonBudget, DEFAULT_KERNEL_ERROR};

/// The kernel-factor rule at relative error `rel`, capped at
/// `max_photons` a channel.
pub fn kernel_factor(rel: f64, max_photons: u64) -> PhotonBudget {
    PhotonBudget::KernelFactor { rel, max_photons }
}

/// The total-and-profile rule at relative error `rel`, capped at
/// `max_photons` a channel.
pub fn target_error(rel: f64, max_photons: u64) -> PhotonBudget {
    PhotonBudget::TargetError { rel, max_photons }
}

/// The default rule (kernel-factor at `DEFAULT_KERNEL_ERROR`, capped at
/// 10^8 photons a channel) on every channel with seed `seed`: the run
/// whose absolute floor stops beer.
pub fn default_rule(seed: u64) -> McConfig {
    McConfig {
        budget: kernel_factor(DEFAULT_KERNEL_ERROR, 100_000_000),
        seed,
        threads: None,
        channels: Channel::ALL.to_vec(),
        grid: None,
    }
}
