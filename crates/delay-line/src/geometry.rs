//! The optical path an interferometer's delay line must add: the geometric delay of a star
//! between two telescopes, `D = B · ŝ`, and its rate as the Earth turns (docs/delay-line.md
//! §1).
//!
//! The baseline `B` runs from telescope 1 to telescope 2 in the site's local east, north,
//! up frame (length, azimuth from north through east, elevation above the horizon); the
//! star's unit vector `ŝ` in the same frame follows from its hour angle `H`, declination
//! `δ` and the site's latitude `φ` (Lawson 2000, ch. 2; Thompson, Moran & Swenson 2017,
//! §4.1):
//!
//! ```text
//! ŝ_E = −cos δ sin H
//! ŝ_N =  cos φ sin δ − sin φ cos δ cos H
//! ŝ_U =  sin φ sin δ + cos φ cos δ cos H
//! ```
//!
//! The wavefront reaches telescope 2 earlier by `D`, so the delay line of telescope 2's arm
//! adds `D` of optical path. `H` grows at the Earth's sidereal rate `ω⊕`, so
//! `dD/dt = ω⊕ B · dŝ/dH`, at most `ω⊕ |B|` (0.73 mm/s for 10 m).

/// The Earth's rotation rate relative to the stars (rad/s): 7.292115 × 10⁻⁵, the IERS
/// conventional value (IERS Conventions 2010, Table 1.1).
pub const EARTH_ROTATION_RATE: f64 = 7.292_115e-5;

/// A baseline, a site and a star: what fixes the geometric delay at every hour angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sidereal {
    /// The baseline from telescope 1 to telescope 2, east, north, up (m).
    baseline: [f64; 3],
    /// The site's latitude (rad).
    latitude: f64,
    /// The star's declination (rad).
    declination: f64,
}

/// A geometry that gives no delay to track, each case naming what is wrong.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    #[error("baseline length {0} m: it must be finite and > 0")]
    Length(f64),
    #[error("{what} {value}°: it must be finite, within ±{limit}°")]
    Angle { what: &'static str, value: f64, limit: f64 },
    #[error(
        "the star is below the horizon at hour angle {hour_angle_deg}° (altitude {altitude_deg}°)"
    )]
    BelowHorizon { hour_angle_deg: f64, altitude_deg: f64 },
}

fn angle(what: &'static str, deg: f64, limit: f64) -> Result<f64, GeometryError> {
    if deg.is_finite() && deg.abs() <= limit {
        Ok(deg.to_radians())
    } else {
        Err(GeometryError::Angle { what, value: deg, limit })
    }
}

impl Sidereal {
    /// A baseline of `length` m at `azimuth_deg` (from north through east) and
    /// `elevation_deg`, at a site of latitude `latitude_deg`, observing a star of
    /// declination `declination_deg`.
    pub fn new(
        length: f64,
        azimuth_deg: f64,
        elevation_deg: f64,
        latitude_deg: f64,
        declination_deg: f64,
    ) -> Result<Sidereal, GeometryError> {
        if !(length.is_finite() && length > 0.0) {
            return Err(GeometryError::Length(length));
        }
        let az = angle("azimuth", azimuth_deg, 360.0)?;
        let el = angle("elevation", elevation_deg, 90.0)?;
        let latitude = angle("latitude", latitude_deg, 90.0)?;
        let declination = angle("declination", declination_deg, 90.0)?;
        let baseline =
            [length * el.cos() * az.sin(), length * el.cos() * az.cos(), length * el.sin()];
        Ok(Sidereal { baseline, latitude, declination })
    }

    /// The star's unit vector (east, north, up) at hour angle `h` (rad).
    pub fn star(&self, h: f64) -> [f64; 3] {
        let (sd, cd) = self.declination.sin_cos();
        let (sp, cp) = self.latitude.sin_cos();
        let (sh, ch) = h.sin_cos();
        [-cd * sh, cp * sd - sp * cd * ch, sp * sd + cp * cd * ch]
    }

    /// The star's altitude above the horizon at hour angle `h` (rad).
    pub fn altitude(&self, h: f64) -> f64 {
        self.star(h)[2].clamp(-1.0, 1.0).asin()
    }

    /// Refuses an hour angle at which the star is below the horizon.
    pub fn visible(&self, h: f64) -> Result<(), GeometryError> {
        let altitude = self.altitude(h);
        if altitude > 0.0 {
            Ok(())
        } else {
            Err(GeometryError::BelowHorizon {
                hour_angle_deg: h.to_degrees(),
                altitude_deg: altitude.to_degrees(),
            })
        }
    }

    /// The geometric delay `D = B · ŝ` at hour angle `h` (m).
    pub fn delay(&self, h: f64) -> f64 {
        dot(self.baseline, self.star(h))
    }

    /// `dD/dt` at hour angle `h` (m/s): `ω⊕ B · dŝ/dH`.
    pub fn rate(&self, h: f64) -> f64 {
        let cd = self.declination.cos();
        let (sp, cp) = self.latitude.sin_cos();
        let (sh, ch) = h.sin_cos();
        let ds = [-cd * ch, sp * cd * sh, -cp * cd * sh];
        EARTH_ROTATION_RATE * dot(self.baseline, ds)
    }

    /// The hour angle `t` seconds after hour angle `h0` (rad).
    pub fn hour_angle(h0: f64, t: f64) -> f64 {
        h0 + EARTH_ROTATION_RATE * t
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// The star's vector by rotations of its equatorial one: `ŝ_eq = (cos δ cos H,
    /// −cos δ sin H, sin δ)` in (meridian, west→east, pole) axes, turned into east, north,
    /// up by the colatitude: an independent route to the same vector.
    fn star_by_rotation(s: &Sidereal, h: f64) -> [f64; 3] {
        let (x, y, z) =
            (s.declination.cos() * h.cos(), -s.declination.cos() * h.sin(), s.declination.sin());
        // Rotate about the east axis by the colatitude `c`: the pole is at altitude φ in
        // the north, the meridian's equator point at altitude 90° − φ in the south.
        let c = FRAC_PI_2 - s.latitude;
        let north = z * c.sin() - x * c.cos();
        let up = z * c.cos() + x * c.sin();
        [y, north, up]
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn delay_equals_the_rotated_star_projected_on_the_baseline() {
        let mut worst: f64 = 0.0;
        for (az, el, lat, dec) in
            [(90.0, 0.0, -24.6, -30.0), (37.0, 2.0, 19.8, 45.0), (0.0, 0.0, 34.2, 10.0)]
        {
            let s = Sidereal::new(100.0, az, el, lat, dec).unwrap();
            for k in -12..=12 {
                let h = k as f64 * 0.1;
                let want = dot(s.baseline, star_by_rotation(&s, h));
                if want.abs() > 1e-3 {
                    worst = worst.max(rel(s.delay(h), want));
                }
            }
        }
        assert!(worst < 1e-12, "worst relative difference {worst:e}");
    }

    /// An east-west baseline: `D = −L cos δ sin H`, `dD/dt = −ω⊕ L cos δ cos H`, the
    /// largest rate `ω⊕ L` on the celestial equator at transit.
    #[test]
    fn east_west_baseline_in_closed_form() {
        let (l, dec) = (10.0, 20.0_f64);
        let s = Sidereal::new(l, 90.0, 0.0, -24.6, dec).unwrap();
        let cd = dec.to_radians().cos();
        for k in -10..=10 {
            let h = k as f64 * 0.13 + 0.01;
            assert!(rel(s.delay(h), -l * cd * h.sin()) < 1e-12, "H = {h}");
            assert!(rel(s.rate(h), -EARTH_ROTATION_RATE * l * cd * h.cos()) < 1e-12, "H = {h}");
        }
        let equator = Sidereal::new(10.0, 90.0, 0.0, 0.0, 0.0).unwrap();
        assert!(rel(equator.rate(0.0).abs(), 7.292115e-4) < 1e-12);
    }

    /// The rate is the derivative of the delay: a fourth-order central difference over
    /// 1 s of time agrees to its truncation error.
    #[test]
    fn rate_is_the_time_derivative_of_the_delay() {
        let s = Sidereal::new(47.0, 63.0, 1.5, 37.2, 12.0).unwrap();
        let dt = 1.0;
        for k in -8..=8 {
            let h = k as f64 * 0.15 + 0.02;
            let d = |t: f64| s.delay(Sidereal::hour_angle(h, t));
            let numeric = (-d(2.0 * dt) + 8.0 * d(dt) - 8.0 * d(-dt) + d(-2.0 * dt)) / (12.0 * dt);
            assert!(rel(s.rate(h), numeric) < 1e-9, "H = {h}: {} vs {numeric}", s.rate(h));
        }
    }

    #[test]
    fn bad_geometry_is_refused_by_name() {
        assert_eq!(Sidereal::new(0.0, 0.0, 0.0, 0.0, 0.0), Err(GeometryError::Length(0.0)));
        assert!(matches!(
            Sidereal::new(f64::NAN, 0.0, 0.0, 0.0, 0.0),
            Err(GeometryError::Length(_))
        ));
        let e = Sidereal::new(10.0, 0.0, 0.0, 91.0, 0.0).unwrap_err();
        assert_eq!(e.to_string(), "latitude 91°: it must be finite, within ±90°");
        // A star at declination −60° never rises at latitude +40°.
        let s = Sidereal::new(10.0, 90.0, 0.0, 40.0, -60.0).unwrap();
        assert!(matches!(s.visible(0.0), Err(GeometryError::BelowHorizon { .. })));
        assert!(Sidereal::new(10.0, 90.0, 0.0, -24.6, -60.0).unwrap().visible(0.0).is_ok());
    }
}
