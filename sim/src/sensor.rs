//! The camera's sensor (TOML table `[world.camera.sensor]`): exposure blur, photon shot noise, read
//! noise, gain, an optional gamma and quantisation, applied where frames are made (the renderer,
//! [`crate::Renderer::collect_batch`]) so that every frame of the runner, the env, `loomlab render`
//! and `loomlab detect` passes through it once.
//!
//! **The model**, per pixel, in this order:
//! 1. *Exposure*: the rendered luminance L ∈ [0, 1] is the mean of `subframes` views at evenly
//!    spaced times (the midpoint rule) over the exposure `[t − exposure_s, t]` that ends at the
//!    frame's time `t`. Between two camera frames every body's pose and the camera's pose are
//!    interpolated (linearly in position, spherically in rotation) from the previous frame's to the
//!    current one's; the first frame of an episode (nothing before it) is not blurred. The
//!    renderer samples each pixel at its centre, so a sharp edge's blur is a staircase of
//!    `subframes` steps that equals the analytic box-filtered edge within `1 / (2 · subframes)`.
//!    **Cost**: `subframes` renders per frame (`loomlab run` of the default suite: see
//!    docs/benchmarks.md); `exposure_s = 0` renders once.
//! 2. *Electrons* (linear domain): L is the fraction of the full well the pixel collects,
//!    `μ = L · full_well_e` electrons; photon shot noise (Poisson, drawn as its Gaussian
//!    approximation with the same mean and variance μ) and read noise (Gaussian, `read_noise_e`
//!    electrons RMS) are added, as one Gaussian of their summed variance:
//!    `e = μ + √(μ + read_noise_e²) · z` (z from a table of 65 536 normal quantiles).
//! 3. *Gain*: `v = gain · e / full_well_e` (without noise, `v = gain · L`), clipped to [0, 1].
//!    Mean and variance of v before clipping: `gain · L` and `gain² · (μ + read_noise_e²) / full_well_e²`.
//! 4. *Gamma* (optional): `v ← v^(1 / gamma)`, a display encoding (gamma 1: linear).
//! 5. *Quantisation* (optional): `v ← round(v · (2^bits − 1)) / (2^bits − 1)`.
//!
//! **Determinism**: the noise of frame k of an episode is drawn from a generator seeded by the
//! simulator's seed, on stream k, so it depends on the seed and the frame index only: the same
//! seed gives the same noisy frames however frames are batched, and a closed-loop tail sees the
//! open loop's noise up to its alarm. **The defaults are the ideal camera**: no blur, no noise,
//! gain 1, linear, no quantisation; such a sensor is not applied at all (frames bit-identical to a
//! world without the table).

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::SimError;

/// The camera's sensor (`[world.camera.sensor]`); every default is the ideal camera's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorDesc {
    /// Exposure time (s) over which motion blurs the frame, ending at the frame's time; at most one
    /// camera period (`1 / world.camera_hz`). Default 0 (an instantaneous global shutter).
    pub exposure_s: f64,
    /// Views rendered and averaged per frame when `exposure_s > 0` (each one a render: the frame
    /// costs this many), 1..=[`MAX_SUBFRAMES`]. Default 4.
    pub subframes: u32,
    /// Full-well capacity (electrons): how many electrons a pixel at luminance 1 collects; sets the
    /// photon shot noise (relative noise `1/√(L · full_well_e)`). Default 0: no shot or read noise.
    pub full_well_e: f64,
    /// Read noise (electrons RMS per pixel and frame); needs `full_well_e > 0`. Default 0.
    pub read_noise_e: f64,
    /// Gain applied to the collected signal (output = gain · electrons / full_well_e, clipped to
    /// [0, 1]). Default 1.
    pub gain: f64,
    /// Quantisation of the output to `bits` bits (1..=16); 0 keeps floats. Default 0.
    pub bits: u32,
    /// Display gamma: the output is encoded as `v^(1/gamma)`; 1 is linear. Default 1.
    pub gamma: f64,
}

/// The most sub-frames one frame may average ([`SensorDesc::subframes`]).
pub const MAX_SUBFRAMES: u32 = 256;

impl Default for SensorDesc {
    fn default() -> Self {
        SensorDesc {
            exposure_s: 0.0,
            subframes: 4,
            full_well_e: 0.0,
            read_noise_e: 0.0,
            gain: 1.0,
            bits: 0,
            gamma: 1.0,
        }
    }
}

impl SensorDesc {
    /// True when the sensor changes nothing (no blur, no noise, gain 1, no quantisation, gamma 1):
    /// the ideal camera, whose frames are the renderer's, bit for bit.
    pub fn is_ideal(&self) -> bool {
        self.exposure_s == 0.0 && self.full_well_e == 0.0 && self.gain == 1.0 && self.bits == 0 && self.gamma == 1.0
    }

    /// Validates the description for a camera period of `period_s` seconds: `None` for the ideal
    /// camera (nothing to apply).
    pub fn build(&self, period_s: f64) -> Result<Option<Sensor>, SimError> {
        let key = |k: &str| format!("world.camera.sensor.{k}");
        let finite_nonneg = |k: &str, v: f64, what: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(SimError::invalid(
                    key(k),
                    v,
                    format!("must be finite and >= 0 ({what})"),
                ))
            }
        };
        finite_nonneg("exposure_s", self.exposure_s, "seconds; 0 = no blur")?;
        if self.exposure_s > period_s * (1.0 + 1e-9) {
            return Err(SimError::invalid(
                key("exposure_s"),
                self.exposure_s,
                format!(
                    "must be at most one camera period ({period_s} s = 1 / world.camera_hz): lower it or lower \
                     world.camera_hz"
                ),
            ));
        }
        if !(1..=MAX_SUBFRAMES).contains(&self.subframes) {
            return Err(SimError::invalid(
                key("subframes"),
                self.subframes,
                format!("must be in 1..={MAX_SUBFRAMES} (renders averaged per frame)"),
            ));
        }
        finite_nonneg("full_well_e", self.full_well_e, "electrons; 0 = no noise")?;
        finite_nonneg("read_noise_e", self.read_noise_e, "electrons RMS")?;
        if self.read_noise_e > 0.0 && self.full_well_e == 0.0 {
            return Err(SimError::invalid(
                key("read_noise_e"),
                self.read_noise_e,
                "needs world.camera.sensor.full_well_e > 0 (read noise is in electrons of that well)",
            ));
        }
        if !(self.gain.is_finite() && self.gain > 0.0 && self.gain <= 1000.0) {
            return Err(SimError::invalid(key("gain"), self.gain, "must be in (0, 1000]"));
        }
        if self.bits > 16 {
            return Err(SimError::invalid(
                key("bits"),
                self.bits,
                "must be in 0..=16 (0 keeps floating-point frames)",
            ));
        }
        if !(self.gamma.is_finite() && self.gamma >= 0.1 && self.gamma <= 10.0) {
            return Err(SimError::invalid(
                key("gamma"),
                self.gamma,
                "must be in [0.1, 10] (1 = linear)",
            ));
        }
        if self.is_ideal() {
            return Ok(None);
        }
        Ok(Some(Sensor { desc: *self, period_s }))
    }
}

/// A validated, non-ideal sensor ([`SensorDesc::build`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    desc: SensorDesc,
    period_s: f64,
}

/// Salt of the noise generator's seed (the simulator's seed is mixed with it).
const NOISE_SALT: u64 = 0x5345_4e53_4f52_4e5a;

impl Sensor {
    /// The description it was built from.
    pub fn desc(&self) -> &SensorDesc {
        &self.desc
    }

    /// Views rendered per frame: `subframes` with an exposure, else 1.
    pub fn views_per_frame(&self) -> usize {
        if self.desc.exposure_s > 0.0 {
            self.desc.subframes as usize
        } else {
            1
        }
    }

    /// For sub-frame `j` of [`Self::views_per_frame`], how far back from the frame's time it is, as
    /// a fraction of the camera period (0 = the frame's time, 1 = the previous frame's): the
    /// midpoint rule over `[t − exposure_s, t]`.
    pub fn subframe_lag(&self, j: usize) -> f64 {
        let k = self.views_per_frame() as f64;
        let back_s = self.desc.exposure_s * (1.0 - (j as f64 + 0.5) / k);
        (back_s / self.period_s).clamp(0.0, 1.0)
    }

    /// Applies steps 2–5 of the model (noise, gain, gamma, quantisation) to the exposure-averaged
    /// `frame` of frame index `frame_index` of a simulator seeded with `seed`.
    pub fn apply(&self, frame: &mut [f32], seed: u64, frame_index: u64) {
        let d = &self.desc;
        if d.full_well_e > 0.0 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ NOISE_SALT);
            rng.set_stream(frame_index);
            let table = normal_table();
            let scale = d.gain / d.full_well_e;
            let read_var = d.read_noise_e * d.read_noise_e;
            for quad in frame.chunks_mut(4) {
                let bits = rng.next_u64();
                for (i, v) in quad.iter_mut().enumerate() {
                    // shot noise (variance μ) and read noise (read²) together: one Gaussian
                    let z = table[((bits >> (16 * i)) & 0xffff) as usize];
                    let mu = f64::from(*v).max(0.0) * d.full_well_e;
                    let e = mu + (mu + read_var).sqrt() * z;
                    *v = (e * scale).clamp(0.0, 1.0) as f32;
                }
            }
        } else if d.gain != 1.0 {
            for v in frame.iter_mut() {
                *v = (f64::from(*v) * d.gain).clamp(0.0, 1.0) as f32;
            }
        }
        if d.gamma != 1.0 {
            let inv = 1.0 / d.gamma;
            for v in frame.iter_mut() {
                *v = f64::from(v.clamp(0.0, 1.0)).powf(inv) as f32;
            }
        }
        if d.bits > 0 {
            let levels = f64::from((1u32 << d.bits) - 1);
            for v in frame.iter_mut() {
                *v = ((f64::from(v.clamp(0.0, 1.0)) * levels).round() / levels) as f32;
            }
        }
    }
}

/// Standard normal numbers by a 16-bit index: the quantiles `Φ⁻¹((i + ½) / 65 536)`, scaled to
/// mean 0 and variance 1 exactly (the noise draws one per pixel: a table look-up instead of a
/// Box–Muller transform, ~10× faster; the distribution is exact to within its 2⁻¹⁶ steps and its
/// tails end at ±4.3σ).
pub(crate) fn normal_table() -> &'static [f64; 65536] {
    static TABLE: std::sync::OnceLock<Box<[f64; 65536]>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Box::new([0.0f64; 65536]);
        for (i, z) in t.iter_mut().enumerate() {
            *z = inverse_normal_cdf((i as f64 + 0.5) / 65536.0);
        }
        let mean = t.iter().sum::<f64>() / 65536.0;
        let sd = (t.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / 65536.0).sqrt();
        t.iter_mut().for_each(|z| *z = (*z - mean) / sd);
        t
    })
}

/// Φ⁻¹(p) for p in (0, 1): Acklam's rational approximation (relative error below 1.2e-9).
fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// A sensor profile: the camera's sensor and the pipeline's latencies, set on every episode's world
/// by `loomlab run --sensor NAME`, a suite's `sensor = "NAME"` key or `EscapeEnv(sensor=…)`
/// (replacing the scenario files' `[world.camera.sensor]`, `world.camera.perception_latency_s`
/// and `world.robot.actuation_latency_s`).
///
/// - **`ideal`**: today's camera and body: no blur, no noise, floats, no latency.
/// - **`robot`**: a small ground robot with a global-shutter CMOS camera at 120 Hz:
///   - 4 ms exposure (an indoor exposure that keeps a fast ball's smear to a few pixels), 2
///     sub-frames: at 120 Hz a 4 ms exposure moves most objects by under a pixel, so two views
///     render that blur as well as more would, at half the cost of four (the budget is
///     1.5× the `ideal` suite's wall time); the blur's accuracy against the analytic box filter is
///     tested separately with many sub-frames (`sim/tests/sensor.rs`);
///   - 6 000 e⁻ full well and 3 e⁻ read noise (the order of small-pixel CMOS sensors, a few µm
///     pixels: a few thousand electrons of well and a few of read noise), gain 1 so that the suite's
///     luminance 1 fills the well: at the sky's 0.8 a pixel holds 4 800 e⁻, SNR ≈ 69;
///   - 8-bit output, linear (gamma 1: the detectors' models assume linear luminance);
///   - 25 ms perception latency (exposure, readout, transfer and the detector's frame: 3 frames at
///     120 Hz; mjlab models 40–60 ms of camera latency as 2–3 control steps, Falanga et al. 2020
///     dodge with 3.5 ms end to end with an event camera) and 10 ms actuation latency (the motor
///     controller's loop and the drive's response: 1 frame).
/// - **`events`**: the `ideal` camera plus an event camera on the same view (`[world.camera]
///   kind = "events"` with the default [`crate::events::EventCameraDesc`]): the frame rows read its
///   frames, the event rows (`event_soc`, `event_lgmd`) its events.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorProfile {
    /// The profile's name.
    pub name: &'static str,
    /// `[world.camera.sensor]`.
    pub sensor: SensorDesc,
    /// `world.camera.perception_latency_s` (s).
    pub perception_latency_s: f32,
    /// `world.robot.actuation_latency_s` (s).
    pub actuation_latency_s: f32,
    /// `world.camera.kind` ([`crate::events::CameraKind::Events`]: the event camera, with the
    /// default `[world.camera.events]`).
    pub camera_kind: crate::events::CameraKind,
}

/// The names of the sensor profiles ([`SensorProfile::named`]): `ideal`, `robot`, `robot`'s three
/// parts alone (to tell their effects apart): `robot-noise` (its shot and read noise and 8-bit
/// output), `robot-blur` (its exposure), `robot-latency` (its perception and actuation latency),
/// and `events` (the ideal world seen by the event camera, `[world.camera.events]` defaults).
pub const SENSOR_PROFILES: [&str; 6] = ["ideal", "robot", "robot-noise", "robot-blur", "robot-latency", "events"];

impl SensorProfile {
    /// The profile called `name` (one of [`SENSOR_PROFILES`]); an error lists them.
    pub fn named(name: &str) -> Result<SensorProfile, String> {
        let ideal = SensorProfile {
            name: "ideal",
            sensor: SensorDesc::default(),
            perception_latency_s: 0.0,
            actuation_latency_s: 0.0,
            camera_kind: crate::events::CameraKind::Frames,
        };
        let robot = SensorProfile {
            name: "robot",
            sensor: SensorDesc {
                exposure_s: 0.004,
                // two views: under a pixel of blur for most objects at 120 Hz (see above)
                subframes: 2,
                full_well_e: 6000.0,
                read_noise_e: 3.0,
                gain: 1.0,
                bits: 8,
                gamma: 1.0,
            },
            perception_latency_s: 0.025,
            actuation_latency_s: 0.010,
            ..ideal
        };
        match name {
            "ideal" => Ok(ideal),
            "robot" => Ok(robot),
            "robot-noise" => Ok(SensorProfile {
                name: "robot-noise",
                sensor: SensorDesc {
                    exposure_s: 0.0,
                    ..robot.sensor
                },
                ..ideal
            }),
            "robot-blur" => Ok(SensorProfile {
                name: "robot-blur",
                sensor: SensorDesc {
                    exposure_s: robot.sensor.exposure_s,
                    subframes: robot.sensor.subframes,
                    ..SensorDesc::default()
                },
                ..ideal
            }),
            "robot-latency" => Ok(SensorProfile {
                name: "robot-latency",
                sensor: SensorDesc::default(),
                ..robot
            }),
            "events" => Ok(SensorProfile {
                name: "events",
                camera_kind: crate::events::CameraKind::Events,
                ..ideal
            }),
            other => Err(format!(
                "unknown sensor profile `{other}`; known profiles: {}",
                SENSOR_PROFILES.join(", ")
            )),
        }
    }

    /// Sets the profile's sensor and latencies on `world`.
    pub fn apply(&self, world: &mut crate::WorldDesc) {
        world.camera.sensor = self.sensor;
        world.camera.perception_latency_s = self.perception_latency_s;
        world.robot.actuation_latency_s = self.actuation_latency_s;
        world.camera.kind = self.camera_kind;
        if self.camera_kind == crate::events::CameraKind::Frames {
            // a frame camera reads no event parameters; under `events` a scenario keeps its own
            world.camera.events = crate::events::EventCameraDesc::default();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_robot_profiles_parts_add_up_to_it() {
        let named = |n| SensorProfile::named(n).unwrap();
        let (robot, noise, blur, latency) = (
            named("robot"),
            named("robot-noise"),
            named("robot-blur"),
            named("robot-latency"),
        );
        let joined = SensorDesc {
            exposure_s: blur.sensor.exposure_s,
            subframes: blur.sensor.subframes,
            ..noise.sensor
        };
        assert_eq!(joined, robot.sensor);
        assert_eq!(noise.sensor.exposure_s, 0.0);
        assert!(latency.sensor.is_ideal());
        assert_eq!(
            (latency.perception_latency_s, latency.actuation_latency_s),
            (robot.perception_latency_s, robot.actuation_latency_s)
        );
        for part in [&noise, &blur] {
            assert_eq!((part.perception_latency_s, part.actuation_latency_s), (0.0, 0.0));
        }
        for name in SENSOR_PROFILES {
            assert_eq!(named(name).name, name);
        }
        assert!(
            SensorProfile::named("robot-fast")
                .unwrap_err()
                .contains("robot-latency")
        );
    }

    #[test]
    fn defaults_are_ideal_and_build_to_nothing() {
        assert!(SensorDesc::default().is_ideal());
        assert_eq!(SensorDesc::default().build(1.0 / 120.0).unwrap(), None);
    }

    #[test]
    fn bad_values_name_the_key() {
        let bad = SensorDesc {
            exposure_s: 0.02,
            ..SensorDesc::default()
        };
        let e = bad.build(1.0 / 120.0).unwrap_err().to_string();
        assert!(
            e.contains("world.camera.sensor.exposure_s") && e.contains("camera period"),
            "{e}"
        );
        let bad = SensorDesc {
            read_noise_e: 3.0,
            ..SensorDesc::default()
        };
        let e = bad.build(1.0).unwrap_err().to_string();
        assert!(e.contains("read_noise_e") && e.contains("full_well_e"), "{e}");
        for bad in [
            SensorDesc {
                bits: 17,
                ..SensorDesc::default()
            },
            SensorDesc {
                gain: f64::NAN,
                ..SensorDesc::default()
            },
            SensorDesc {
                subframes: 0,
                ..SensorDesc::default()
            },
            SensorDesc {
                gamma: 0.0,
                ..SensorDesc::default()
            },
        ] {
            assert!(bad.build(1.0).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn the_normal_table_is_standard_normal() {
        let t = normal_table();
        assert!((inverse_normal_cdf(0.975) - 1.959_963_985).abs() < 1e-8);
        assert!((inverse_normal_cdf(0.001) + 3.090_232_306).abs() < 1e-8);
        let within_1sd = t.iter().filter(|z| z.abs() < 1.0).count() as f64 / 65536.0;
        assert!((within_1sd - 0.682_689).abs() < 1e-3, "{within_1sd}");
    }

    #[test]
    fn profiles_by_name() {
        assert_eq!(SensorProfile::named("ideal").unwrap().sensor, SensorDesc::default());
        let robot = SensorProfile::named("robot").unwrap();
        assert!(robot.sensor.build(1.0 / 120.0).unwrap().is_some());
        let e = SensorProfile::named("nosuch").unwrap_err();
        assert!(e.contains("ideal, robot"), "{e}");
    }

    #[test]
    fn quantisation_and_gamma() {
        let s = SensorDesc {
            bits: 2,
            gamma: 2.0,
            ..SensorDesc::default()
        }
        .build(1.0)
        .unwrap()
        .unwrap();
        let mut f = vec![0.0, 0.25, 1.0];
        s.apply(&mut f, 0, 0);
        // 0.25^(1/2) = 0.5 → round(1.5) / 3 = 2/3
        assert_eq!(f, vec![0.0, 2.0 / 3.0, 1.0]);
    }
}
