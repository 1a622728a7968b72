//! The accepted values of the techniques' settings, in one place: each setting's
//! [`Bounds`] is what its validation checks, what its error message says, and what the
//! viewer's widget offers, so the three cannot drift apart.

use crate::{Error, Result};
use std::fmt::Display;
use std::ops::RangeInclusive;

/// The inclusive range of one numeric setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds<T> {
    /// The setting as messages name it (`"lpv size"`, as in `[settings.lpv] size`).
    pub name: &'static str,
    /// Least accepted value.
    pub min: T,
    /// Greatest accepted value.
    pub max: T,
    /// What the values count, for messages (`"probes per axis"`), or empty.
    pub unit: &'static str,
}

impl<T: PartialOrd + Copy + Display> Bounds<T> {
    /// Bounds `min..=max` of setting `name`.
    pub const fn new(name: &'static str, min: T, max: T) -> Bounds<T> {
        Bounds {
            name,
            min,
            max,
            unit: "",
        }
    }

    /// The same bounds, counting `unit` in messages.
    pub const fn counting(self, unit: &'static str) -> Bounds<T> {
        Bounds { unit, ..self }
    }

    /// The values as a range (for widgets and `contains`).
    pub fn range(&self) -> RangeInclusive<T> {
        self.min..=self.max
    }

    /// Whether `value` is accepted (NaN never is).
    pub fn contains(&self, value: T) -> bool {
        self.range().contains(&value)
    }

    /// The bounds as messages write them: `2..=128 probes per axis`.
    pub fn text(&self) -> String {
        match self.unit {
            "" => format!("{}..={}", self.min, self.max),
            unit => format!("{}..={} {unit}", self.min, self.max),
        }
    }

    /// An error naming the setting and its bounds unless `value` is within them.
    pub fn check(&self, value: T) -> Result<()> {
        require(self.contains(value), self.name, &self.text())
    }
}

/// An error "`what` must be `accepted`" unless `ok`: for conditions that are not a plain range
/// (powers of two, orderings, optional values).
pub fn require(ok: bool, what: &str, accepted: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!("{what} must be {accepted}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_check_and_say_the_same() {
        const SIZE: Bounds<u32> = Bounds::new("lpv size", 2, 128);
        assert!(SIZE.check(2).is_ok() && SIZE.check(128).is_ok());
        let e = SIZE.check(129).unwrap_err().to_string();
        assert!(e.contains("lpv size must be 2..=128"), "{e}");
        let grid = Bounds::new("probes grid", 2u32, 128).counting("probes per axis");
        assert_eq!(grid.text(), "2..=128 probes per axis");
        const BIAS: Bounds<f32> = Bounds::new("probes normal_bias", 0.0, 1.0);
        assert!(!BIAS.contains(f32::NAN));
    }
}
