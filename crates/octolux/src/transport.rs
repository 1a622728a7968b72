//! How much light transport an image holds, counted in bounces: shared by the reference path
//! tracer, the techniques' claims and the command line.

use crate::{Error, Result};

/// Hard limit on path length for [`Bounces::Unlimited`] (vertices after the primary hit).
pub const MAX_PATH_VERTICES: u32 = 256;

/// Which light paths an image holds: what the reference computes and what a technique claims
/// to compute (so each is judged against the matching reference).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounces {
    /// Emission seen directly and punctual light reflected once; `indirect` stays black.
    DirectOnly,
    /// Direct light plus exactly `n` indirect bounces (`Indirect(1)` is one-bounce GI).
    Indirect(u32),
    /// Full multi-bounce transport (Russian roulette, unbiased).
    Unlimited,
}

impl Bounces {
    /// Largest number of indirect bounces.
    pub fn max_indirect(self) -> u32 {
        match self {
            Bounces::DirectOnly => 0,
            Bounces::Indirect(n) => n.min(MAX_PATH_VERTICES),
            Bounces::Unlimited => MAX_PATH_VERTICES,
        }
    }
}

impl std::str::FromStr for Bounces {
    type Err = Error;

    /// `direct`, `unlimited` (or `all`), or a number of indirect bounces (`0` = direct).
    ///
    /// ```
    /// use octolux::transport::Bounces;
    /// assert_eq!("1".parse::<Bounces>().unwrap(), Bounces::Indirect(1));
    /// assert_eq!("direct".parse::<Bounces>().unwrap(), Bounces::DirectOnly);
    /// assert!("lots".parse::<Bounces>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<Bounces> {
        match s.trim().to_lowercase().as_str() {
            "direct" | "0" => Ok(Bounces::DirectOnly),
            "unlimited" | "all" | "inf" => Ok(Bounces::Unlimited),
            n => n.parse::<u32>().map(Bounces::Indirect).map_err(|_| {
                Error::InvalidArgument(format!(
                    "bounces '{s}': expected 'direct', 'unlimited' or a number"
                ))
            }),
        }
    }
}

impl std::fmt::Display for Bounces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Bounces::DirectOnly => write!(f, "direct"),
            Bounces::Indirect(n) => write!(f, "{n} bounce{}", if *n == 1 { "" } else { "s" }),
            Bounces::Unlimited => write!(f, "unlimited"),
        }
    }
}
