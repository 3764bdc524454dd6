//! Validation of every received message: finite values, indices in range, matching
//! counts and protocol version. Errors name the element and the field.

use crate::payload::{BodyLoad, BodyState, CouplingPoint, PROTOCOL_VERSION, WindowHeader};

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValidationError {
    #[error("{what}: protocol version {got}, this build speaks {expected}")]
    Version {
        what: &'static str,
        got: u32,
        expected: u32,
    },
    #[error("{what}: header announces {announced} elements, the slice holds {actual}")]
    Count {
        what: &'static str,
        announced: u32,
        actual: usize,
    },
    #[error("{what}[{index}].{field} = {value} is not finite")]
    NonFinite {
        what: &'static str,
        index: usize,
        field: &'static str,
        value: f64,
    },
    #[error("{what}[{index}].body = {body} is out of range (the scene has {bodies} bodies)")]
    BodyIndex {
        what: &'static str,
        index: usize,
        body: u32,
        bodies: usize,
    },
    #[error("{what}[{index}].{field} = {value} must not be negative")]
    Negative {
        what: &'static str,
        index: usize,
        field: &'static str,
        value: f64,
    },
}

fn finite<const N: usize, T: Into<f64> + Copy>(
    what: &'static str,
    index: usize,
    field: &'static str,
    v: [T; N],
) -> Result<(), ValidationError> {
    for x in v {
        let x: f64 = x.into();
        if !x.is_finite() {
            return Err(ValidationError::NonFinite {
                what,
                index,
                field,
                value: x,
            });
        }
    }
    Ok(())
}

fn body_in_range(
    what: &'static str,
    index: usize,
    body: u32,
    bodies: usize,
) -> Result<(), ValidationError> {
    if (body as usize) < bodies {
        Ok(())
    } else {
        Err(ValidationError::BodyIndex {
            what,
            index,
            body,
            bodies,
        })
    }
}

/// Checks the header of a windowed sample against its slice.
pub fn validate_header(
    what: &'static str,
    h: &WindowHeader,
    len: usize,
) -> Result<(), ValidationError> {
    if h.protocol_version != PROTOCOL_VERSION {
        return Err(ValidationError::Version {
            what,
            got: h.protocol_version,
            expected: PROTOCOL_VERSION,
        });
    }
    if h.count as usize != len {
        return Err(ValidationError::Count {
            what,
            announced: h.count,
            actual: len,
        });
    }
    finite(what, 0, "header.time", [h.time, h.window])
}

pub fn validate_points(points: &[CouplingPoint], bodies: usize) -> Result<(), ValidationError> {
    const W: &str = "coupling_point";
    for (i, p) in points.iter().enumerate() {
        finite(W, i, "position", p.position)?;
        finite(W, i, "velocity", p.velocity)?;
        finite(W, i, "normal", p.normal)?;
        finite(W, i, "measure", [p.measure])?;
        // 0 is a fill point of a resolved body (no surface: CouplingPoint::measure).
        if p.measure < 0.0 {
            return Err(ValidationError::Negative {
                what: W,
                index: i,
                field: "measure",
                value: p.measure as f64,
            });
        }
        body_in_range(W, i, p.body, bodies)?;
    }
    Ok(())
}

pub fn validate_states(states: &[BodyState], bodies: usize) -> Result<(), ValidationError> {
    const W: &str = "body_state";
    for (i, s) in states.iter().enumerate() {
        finite(W, i, "position", s.position)?;
        finite(W, i, "orientation", s.orientation)?;
        finite(W, i, "linear_velocity", s.linear_velocity)?;
        finite(W, i, "angular_velocity", s.angular_velocity)?;
        finite(W, i, "mass", [s.mass, s.volume])?;
        body_in_range(W, i, s.body, bodies)?;
    }
    Ok(())
}

pub fn validate_loads(loads: &[BodyLoad], bodies: usize) -> Result<(), ValidationError> {
    const W: &str = "body_load";
    for (i, l) in loads.iter().enumerate() {
        finite(W, i, "force", l.force)?;
        finite(W, i, "moment", l.moment)?;
        body_in_range(W, i, l.body, bodies)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_in_point_names_the_field() {
        let mut p = vec![
            CouplingPoint {
                measure: 1e-6,
                ..Default::default()
            };
            3
        ];
        p[2].velocity[1] = f32::NAN;
        let e = validate_points(&p, 1).unwrap_err();
        assert!(
            matches!(
                e,
                ValidationError::NonFinite {
                    index: 2,
                    field: "velocity",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("coupling_point[2].velocity"));
    }

    /// A fill point (measure 0, resolved bodies under Adami's wall model) passes; a
    /// negative measure is refused, naming the field.
    #[test]
    fn zero_measure_passes_and_a_negative_one_is_refused() {
        let mut p = vec![CouplingPoint::default(); 2];
        validate_points(&p, 1).unwrap();
        p[1].measure = -1e-6;
        let e = validate_points(&p, 1).unwrap_err();
        assert!(
            matches!(
                e,
                ValidationError::Negative {
                    index: 1,
                    field: "measure",
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn out_of_range_body_is_rejected() {
        let l = [BodyLoad {
            body: 4,
            ..Default::default()
        }];
        let e = validate_loads(&l, 2).unwrap_err();
        assert_eq!(
            e,
            ValidationError::BodyIndex {
                what: "body_load",
                index: 0,
                body: 4,
                bodies: 2
            }
        );
    }

    #[test]
    fn header_with_other_version_is_rejected() {
        let mut h = WindowHeader::new(0, 0.0, 1e-4, 1);
        h.protocol_version = PROTOCOL_VERSION + 1;
        assert!(matches!(
            validate_header("loads", &h, 1),
            Err(ValidationError::Version { .. })
        ));
        let h = WindowHeader::new(0, 0.0, 1e-4, 2);
        assert!(matches!(
            validate_header("loads", &h, 1),
            Err(ValidationError::Count { .. })
        ));
    }
}
