//! How much light transport an image holds, counted in bounces: shared by the reference path
//! tracer, the techniques' claims and the command line.
//!
//! One meaning for every kind of light, the one Mitsuba and users use: a path's light is
//! counted by the number of times it is reflected between its emitter and the eye. `direct`
//! is light arriving straight from an emitter (point, spot, directional, the sky or an
//! emissive surface) and reflected once towards the eye, plus emission seen directly; each
//! bounce adds one more reflection.

use crate::{Error, Result};

/// Hard limit on path length for [`Bounces::Unlimited`] (vertices after the primary hit).
pub const MAX_PATH_VERTICES: u32 = 256;

/// Which light paths an image holds: what the reference computes and what a technique claims
/// to compute (so each is judged against the matching reference).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounces {
    /// Emission seen directly and light arriving straight from any emitter reflected once
    /// (Mitsuba's `max_depth` 2); `indirect` stays black.
    DirectOnly,
    /// Direct light plus exactly `n` more reflections (`Indirect(1)` is one-bounce GI,
    /// Mitsuba's `max_depth` n + 2).
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

    /// Largest number of reflections between an emitter and the eye (1 for direct light).
    pub fn max_reflections(self) -> u32 {
        self.max_indirect() + 1
    }

    /// The transport that ends after `reflections` reflections (`None` for 0: emission seen
    /// directly only, which no setting describes).
    pub fn from_reflections(reflections: u32) -> Option<Bounces> {
        match reflections {
            0 => None,
            1 => Some(Bounces::DirectOnly),
            r if r > MAX_PATH_VERTICES => Some(Bounces::Unlimited),
            r => Some(Bounces::Indirect(r - 1)),
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

/// How a technique's light from emissive surfaces compares with its light from the other
/// emitters. The reference follows it so that a technique is judged against the transport it
/// really computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum EmissiveSurfaces {
    /// Emissive surfaces light the scene like any other emitter: their light reflected once is
    /// direct light, and it gets as many bounces as the rest (what the reference renders by
    /// default, and what Mitsuba renders).
    #[default]
    LikeLights,
    /// Emissive surfaces are sources of the technique's indirect light (cone tracing and probes
    /// store their emission with the reflected light): their direct light arrives through the
    /// indirect irradiance, and they get one bounce fewer than the other emitters.
    OneBounceFewer,
    /// Emissive surfaces are seen but light nothing (techniques that inject only the lights'
    /// reflected light, and GI off: the renderer's direct pass lights with the lights and the
    /// sky).
    Unlit,
}

impl std::str::FromStr for EmissiveSurfaces {
    type Err = Error;

    /// `lights`, `one-fewer` or `unlit`.
    fn from_str(s: &str) -> Result<EmissiveSurfaces> {
        match s.trim().to_lowercase().as_str() {
            "lights" | "like-lights" => Ok(EmissiveSurfaces::LikeLights),
            "one-fewer" | "indirect" => Ok(EmissiveSurfaces::OneBounceFewer),
            "unlit" => Ok(EmissiveSurfaces::Unlit),
            _ => Err(Error::InvalidArgument(format!(
                "emissive surfaces '{s}': expected 'lights', 'one-fewer' or 'unlit'"
            ))),
        }
    }
}

/// The light transport of an image: bounces of the emitters' light, and how light from
/// emissive surfaces is counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transport {
    /// Bounces of the light of every emitter (of the lights and the sky only, where
    /// `emissive` says otherwise).
    pub bounces: Bounces,
    /// How emissive surfaces light the scene.
    pub emissive: EmissiveSurfaces,
}

impl Transport {
    /// Every emitter alike, `bounces` bounces (what `--against` and the reference's own
    /// `--bounces` mean).
    pub fn uniform(bounces: Bounces) -> Transport {
        Transport {
            bounces,
            emissive: EmissiveSurfaces::LikeLights,
        }
    }

    /// The same transport for a scene with emissive surfaces (`emissive_surfaces`), or
    /// without, where how they are counted makes no difference and every emitter is alike:
    /// renders of the two give the same image, so they share one reference.
    pub fn for_scene(self, emissive_surfaces: bool) -> Transport {
        if emissive_surfaces {
            self
        } else {
            Transport::uniform(self.bounces)
        }
    }

    /// Largest number of reflections of light from lights and the sky (1 = direct).
    pub fn max_light_reflections(self) -> u32 {
        self.bounces.max_reflections()
    }

    /// Largest number of reflections of light from emissive surfaces (0 = seen only).
    pub fn max_emissive_reflections(self) -> u32 {
        match (self.emissive, self.bounces) {
            (EmissiveSurfaces::LikeLights, b)
            | (EmissiveSurfaces::OneBounceFewer, b @ Bounces::Unlimited) => b.max_reflections(),
            (EmissiveSurfaces::OneBounceFewer, b) => b.max_reflections() - 1,
            (EmissiveSurfaces::Unlit, _) => 0,
        }
    }
}

impl From<Bounces> for Transport {
    fn from(bounces: Bounces) -> Transport {
        Transport::uniform(bounces)
    }
}

impl std::fmt::Display for Transport {
    /// The bounces, and how emissive surfaces differ when they do: `1 bounce`,
    /// `1 bounce; emissive surfaces direct`, `1 bounce; emissive surfaces unlit`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.bounces)?;
        let emissive = self.max_emissive_reflections();
        if emissive != self.max_light_reflections() {
            match Bounces::from_reflections(emissive) {
                None => write!(f, "; emissive surfaces unlit")?,
                Some(b) => write!(f, "; emissive surfaces {b}")?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflections_per_emitter_kind() {
        let t = |b, e| Transport {
            bounces: b,
            emissive: e,
        };
        use EmissiveSurfaces::*;
        let one = t(Bounces::Indirect(1), OneBounceFewer);
        assert_eq!(
            (one.max_light_reflections(), one.max_emissive_reflections()),
            (2, 1)
        );
        assert_eq!(one.to_string(), "1 bounce; emissive surfaces direct");
        let direct = t(Bounces::DirectOnly, OneBounceFewer);
        assert_eq!(direct.max_emissive_reflections(), 0);
        assert_eq!(direct.to_string(), "direct; emissive surfaces unlit");
        let all = t(Bounces::Unlimited, OneBounceFewer);
        assert_eq!(all.max_emissive_reflections(), all.max_light_reflections());
        assert_eq!(all.to_string(), "unlimited");
        assert_eq!(t(Bounces::Indirect(3), LikeLights).to_string(), "3 bounces");
        assert_eq!(
            t(Bounces::Indirect(3), OneBounceFewer).to_string(),
            "3 bounces; emissive surfaces 2 bounces"
        );
        assert_eq!(t(Bounces::Indirect(1), Unlit).max_emissive_reflections(), 0);
        for r in 1..300 {
            let b = Bounces::from_reflections(r).unwrap();
            assert_eq!(b.max_reflections(), r.min(MAX_PATH_VERTICES + 1));
        }
        assert_eq!(Bounces::from_reflections(0), None);
    }
}
