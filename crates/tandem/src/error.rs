//! Errors raised when parameters are validated (at set-up, never inside a step).
//!
//! Run-time numerical trouble (a barrier hit, a singular Jacobian, a non-finite value) is not an
//! error: it is recorded as an event with the time and state (see the simulation module).

use thiserror::Error;

/// A parameter that breaks a physical or theoretical condition, or a geometry that cannot work.
///
/// `param` is a dotted path that names the item, e.g. `arms[1].links[0].mass` or `gains.k1[2]`.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ModelError {
    /// A scalar parameter outside its admissible range.
    #[error("{param} = {value}: {reason}")]
    Invalid {
        /// Dotted path of the parameter.
        param: String,
        /// The offending value.
        value: f64,
        /// The condition it breaks.
        reason: String,
    },
    /// A geometric or structural problem (unreachable grasp, mismatched sizes, ...).
    #[error("{what}: {reason}")]
    Geometry {
        /// What is wrong (dotted path or short name).
        what: String,
        /// Why.
        reason: String,
    },
}

impl ModelError {
    /// Shorthand for [`ModelError::Invalid`].
    pub fn invalid(param: impl Into<String>, value: f64, reason: impl Into<String>) -> Self {
        ModelError::Invalid {
            param: param.into(),
            value,
            reason: reason.into(),
        }
    }
    /// Shorthand for [`ModelError::Geometry`].
    pub fn geometry(what: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelError::Geometry {
            what: what.into(),
            reason: reason.into(),
        }
    }
}

/// Check `value > 0` and finite, naming `param` otherwise.
pub fn positive(param: &str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ModelError::invalid(param, value, "must be finite and > 0"))
    }
}

/// Check `value >= 0` and finite, naming `param` otherwise.
pub fn non_negative(param: &str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ModelError::invalid(param, value, "must be finite and >= 0"))
    }
}

/// A number for a message with `decimals` places, switching to three significant digits with an
/// exponent at and above 1e6 in size (`1.000e308`, never the hundreds of digits `{:.3}` prints
/// for a huge value); non-finite values print as `inf`, `-inf`, `NaN`.
pub fn fmt_fixed(v: f64, decimals: usize) -> String {
    if v.is_finite() && v.abs() >= 1e6 {
        format!("{v:.3e}")
    } else {
        format!("{v:.decimals$}")
    }
}

#[cfg(test)]
mod tests {
    use super::fmt_fixed;

    #[test]
    fn fmt_fixed_never_prints_hundreds_of_digits() {
        assert_eq!(fmt_fixed(519.68, 0), "520");
        assert_eq!(fmt_fixed(18.25, 3), "18.250");
        assert_eq!(fmt_fixed(999_999.4, 1), "999999.4");
        assert_eq!(fmt_fixed(1e308, 3), "1.000e308");
        assert_eq!(fmt_fixed(-6.7e305, 2), "-6.700e305");
        assert_eq!(fmt_fixed(f64::INFINITY, 3), "inf");
        assert_eq!(fmt_fixed(f64::NAN, 0), "NaN");
        assert!(fmt_fixed(f64::MAX, 3).len() < 12);
    }
}
