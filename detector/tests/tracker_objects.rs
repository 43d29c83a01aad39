//! The `tracker` following several objects at once ([`Signals::objects`]): hard-edged discs on a
//! uniform background seen by a standing camera (a pixel is a disc's when its centre is inside
//! it), so that each object's image box is known exactly. Two objects at once are both listed
//! with their boxes, two objects crossing keep their numbers, tracks are born, confirmed and lost
//! as documented, and their number is bounded.

use loomlab_detector::baselines::{MAX_TRACKS, Tracker, TrackerConfig};
use loomlab_detector::{Detector, EfferenceCopy, Frame, PerceivedObject, Signals};

const N: usize = 96;
const BACKGROUND: f32 = 0.6;

/// A disc: centre `[row, column]` and radius (pixels), luminance.
#[derive(Clone, Copy)]
struct Disc {
    centre: [f64; 2],
    radius: f64,
    value: f32,
}

impl Disc {
    fn new(row: f64, column: f64, radius: f64, value: f32) -> Self {
        Self {
            centre: [row, column],
            radius,
            value,
        }
    }

    /// Its image box `[x0, x1, y0, y1]` (normalised image coordinates, as
    /// [`loomlab_detector::ImageRegion`]): the disc's own extent, which the tracker's fit of a
    /// disc's image gives (not its whole pixels' box).
    fn image_box(&self) -> [f64; 4] {
        let (x, y) = (|j: f64| 2.0 * j / N as f64 - 1.0, |i: f64| 1.0 - 2.0 * i / N as f64);
        let ([i, j], r) = (self.centre, self.radius);
        [x(j - r), x(j + r), y(i + r), y(i - r)]
    }

    fn covers(&self, i: usize, j: usize) -> bool {
        let (di, dj) = (i as f64 + 0.5 - self.centre[0], j as f64 + 0.5 - self.centre[1]);
        di * di + dj * dj <= self.radius * self.radius
    }

    /// Its centre in normalised image coordinates `[x, y]`.
    fn image_centre(&self) -> [f64; 2] {
        [
            2.0 * self.centre[1] / N as f64 - 1.0,
            1.0 - 2.0 * self.centre[0] / N as f64,
        ]
    }
}

/// A frame of the discs over the uniform background, the first of them in front.
fn frame(discs: &[Disc]) -> Frame {
    let data = (0..N * N)
        .map(|p| {
            let (i, j) = (p / N, p % N);
            discs.iter().find(|d| d.covers(i, j)).map_or(BACKGROUND, |d| d.value)
        })
        .collect();
    Frame::from_f32(N, data).unwrap()
}

/// A fresh tracker (defaults) stepped on the frames of `scene(k)` for k in `0..frames`, the camera
/// standing (its efference copy says so); the first frame shows the background alone.
fn run(frames: usize, scene: impl Fn(usize) -> Vec<Disc>) -> Vec<Signals> {
    let mut d = Tracker::new(TrackerConfig::default()).unwrap();
    let standing = EfferenceCopy {
        dt_s: 1.0 / 120.0,
        height_m: 0.35,
        ..EfferenceCopy::default()
    };
    (0..frames)
        .map(|k| {
            let discs = if k == 0 { Vec::new() } else { scene(k) };
            d.step_moving(&frame(&discs), &standing).unwrap()
        })
        .collect()
}

/// The listed object nearest to `disc`'s centre (by its region's centroid).
fn nearest<'a>(objects: &'a [PerceivedObject], disc: &Disc) -> &'a PerceivedObject {
    let c = disc.image_centre();
    let d = |o: &PerceivedObject| (o.region.centroid[0] - c[0]).hypot(o.region.centroid[1] - c[1]);
    objects
        .iter()
        .min_by(|a, b| d(a).total_cmp(&d(b)))
        .expect("an object is listed")
}

/// One pixel in normalised image coordinates.
const PIXEL: f64 = 2.0 / N as f64;

#[test]
fn two_objects_at_once_are_both_listed_with_their_boxes() {
    let scene = |k: usize| {
        let t = k as f64;
        vec![
            Disc::new(30.0, 20.0 + 0.2 * t, 5.0, 0.1),
            Disc::new(66.0, 72.0 - 0.15 * t, 6.5, 0.9),
        ]
    };
    let signals = run(90, scene);
    let confirm = TrackerConfig::default().confirm_frames;
    // before either track lasted confirm_frames, nothing is listed
    assert!(signals[..confirm].iter().all(|s| s.objects.is_empty()));
    for (k, s) in signals.iter().enumerate().skip(confirm + 5) {
        assert_eq!(s.objects.len(), 2, "frame {k}: {:?}", s.objects);
        // the primary track is listed first, as its single-object outputs say
        assert_eq!(s.region, Some(s.objects[0].region), "frame {k}");
        assert_eq!(s.angular_size_deg, Some(s.objects[0].angular_size_deg), "frame {k}");
        assert_ne!(s.objects[0].id, s.objects[1].id);
        for disc in scene(k) {
            let o = nearest(&s.objects, &disc);
            assert_eq!(o.region.track, Some(o.id));
            let want = disc.image_box();
            let got = [o.region.x[0], o.region.x[1], o.region.y[0], o.region.y[1]];
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() <= 0.5 * PIXEL, "frame {k}: box {got:?} vs {want:?}");
            }
            let size_deg = (want[1] - want[0]) / 2.0 * 60.0;
            assert!(
                (o.angular_size_deg - size_deg).abs() < 0.15 * size_deg,
                "frame {k}: θ̂ {} vs about {size_deg}",
                o.angular_size_deg
            );
        }
    }
    // the two ids stay the same throughout
    let ids = |s: &Signals| {
        let mut ids: Vec<usize> = s.objects.iter().map(|o| o.id).collect();
        ids.sort_unstable();
        ids
    };
    assert_eq!(ids(&signals[confirm + 5]), ids(&signals[89]));
}

/// The ids of the objects nearest to two crossing discs `a` and `b` of `scene(k)` at frame k.
fn crossing_ids(signals: &[Signals], scene: &impl Fn(usize) -> Vec<Disc>, k: usize) -> (usize, usize) {
    let discs = scene(k);
    let objects = &signals[k].objects;
    assert_eq!(objects.len(), 2, "frame {k}: both discs listed: {objects:?}");
    (nearest(objects, &discs[0]).id, nearest(objects, &discs[1]).id)
}

#[test]
fn two_objects_crossing_one_above_the_other_keep_their_ids() {
    // two discs 14 px across moving towards each other along rows whose pixels lie 3 apart (rows
    // 33–46 and 49–62): more than link_px, so their regions stay apart, but within the primary
    // track's margin (a quarter of its size, 3 px), so its grown box overlaps the other disc
    // while they pass
    let scene = |k: usize| {
        let t = k as f64;
        vec![
            Disc::new(40.0, 12.0 + 0.6 * t, 7.0, 0.1),
            Disc::new(56.0, 84.0 - 0.6 * t, 7.0, 0.85),
        ]
    };
    let rows = |d: &Disc| (0..N).filter(|&i| (0..N).any(|j| d.covers(i, j))).collect::<Vec<_>>();
    let (a, b) = (rows(&scene(0)[0]), rows(&scene(0)[1]));
    assert_eq!((a[0], a[a.len() - 1], b[0], b[b.len() - 1]), (33, 46, 49, 62));
    let signals = run(130, scene);
    // they pass each other at frame 60
    let before = crossing_ids(&signals, &scene, 40);
    assert_ne!(before.0, before.1);
    for k in 41..130 {
        assert_eq!(crossing_ids(&signals, &scene, k), before, "frame {k}");
    }
}

#[test]
fn two_objects_crossing_one_in_front_of_the_other_keep_their_ids() {
    // the same row: the dark disc passes in front of the bright one, their regions merge into one
    // for a few frames (the validation gate refuses it, both tracks hold on their fitted motion)
    let scene = |k: usize| {
        let t = k as f64;
        vec![
            Disc::new(46.0, 10.0 + 1.0 * t, 4.0, 0.1),
            Disc::new(46.0, 86.0 - 1.0 * t, 4.0, 0.9),
        ]
    };
    let signals = run(80, scene);
    // they pass each other at frame 38
    let before = crossing_ids(&signals, &scene, 31);
    assert_ne!(before.0, before.1);
    // while merged, each is held near its own position; afterwards each id is back on its disc
    for k in 50..80 {
        assert_eq!(crossing_ids(&signals, &scene, k), before, "frame {k}");
    }
}

#[test]
fn tracks_are_born_confirmed_and_lost_as_documented() {
    let config = TrackerConfig::default();
    let (confirm, hold) = (config.confirm_frames, config.hold_frames);
    let (appear, vanish, blink) = (40, 110, 120);
    let scene = |k: usize| {
        let mut discs = vec![Disc::new(25.0, 20.0 + 0.1 * k as f64, 5.0, 0.1)];
        if (appear..vanish).contains(&k) {
            discs.push(Disc::new(70.0, 70.0, 4.0 + 0.02 * (k - appear) as f64, 0.9));
        }
        // a disc shown for fewer than confirm_frames frames is never listed
        if (blink..blink + confirm - 5).contains(&k) {
            discs.push(Disc::new(70.0, 25.0, 4.0, 0.3));
        }
        discs
    };
    let signals = run(200, scene);
    let listed = |k: usize| signals[k].objects.len();
    // the first disc's track is confirmed at its confirm_frames-th frame (from frame 1)
    assert_eq!(listed(confirm - 1), 0);
    assert_eq!(listed(confirm), 1);
    let first = signals[confirm].objects[0].id;
    // the second: born tentative at `appear`, listed from its confirm_frames-th frame on
    assert_eq!(listed(appear + confirm - 2), 1, "tentative");
    assert_eq!(listed(appear + confirm - 1), 2, "confirmed");
    let second = signals[appear + confirm - 1]
        .objects
        .iter()
        .find(|o| o.id != first)
        .unwrap()
        .id;
    assert_ne!(first, second);
    // after it vanishes it is held for hold_frames frames, then lost
    assert_eq!(listed(vanish + hold - 1), 2, "held");
    assert_eq!(listed(vanish + hold), 1, "lost");
    // the blinking disc never, and the first disc throughout under its first number
    for (k, s) in signals.iter().enumerate().skip(confirm) {
        assert!(s.objects.iter().any(|o| o.id == first), "frame {k}: {:?}", s.objects);
        assert!(s.objects.len() <= 2, "frame {k}: {:?}", s.objects);
        assert!(
            s.objects.iter().all(|o| o.id == first || o.id == second),
            "frame {k}: {:?}",
            s.objects
        );
    }
}

#[test]
fn the_number_of_tracks_is_bounded() {
    // twelve discs drifting on a grid: at most MAX_TRACKS tracks, each listed once
    let scene = |k: usize| {
        (0..12)
            .map(|q| {
                let (row, col) = (12.0 + 24.0 * (q / 4) as f64, 12.0 + 22.0 * (q % 4) as f64);
                Disc::new(
                    row + 0.05 * k as f64,
                    col,
                    3.0 + 0.1 * q as f64,
                    if q % 2 == 0 { 0.1 } else { 0.95 },
                )
            })
            .collect()
    };
    let signals = run(80, scene);
    for (k, s) in signals.iter().enumerate() {
        assert!(s.objects.len() <= MAX_TRACKS, "frame {k}: {}", s.objects.len());
        let mut ids: Vec<usize> = s.objects.iter().map(|o| o.id).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), s.objects.len(), "frame {k}: ids are distinct");
    }
    assert_eq!(signals[79].objects.len(), MAX_TRACKS);
    // no track started beyond the bound: the numbers given are those of the first MAX_TRACKS
    assert!(
        signals[79].objects.iter().all(|o| o.id <= MAX_TRACKS),
        "{:?}",
        signals[79].objects
    );
}

#[test]
fn the_primary_track_continues_another_track_when_it_starts_on_its_region() {
    // the primary track follows the heavier disc; when that one vanishes and its track ends, the
    // primary track starts on the other disc, whose confirmed track it continues: the same number,
    // listed without a gap, while the single-object outputs wait for confirm_frames as before
    let config = TrackerConfig::default();
    let vanish = 50;
    let scene = |k: usize| {
        let mut discs = vec![Disc::new(60.0, 70.0 - 0.05 * k as f64, 4.0, 0.8)];
        if k < vanish {
            discs.insert(0, Disc::new(30.0, 25.0, 5.0, 0.1));
        }
        discs
    };
    let signals = run(vanish + 60, scene);
    let first = signals[40].region.expect("the heavier disc is reported").track;
    let other = signals[40]
        .objects
        .iter()
        .find(|o| Some(o.id) != first)
        .expect("both listed")
        .id;
    // the primary track holds hold_frames frames, then ends; the next frame it starts on the other
    // disc and continues its track
    let restart = vanish + config.hold_frames + 1;
    for (k, s) in signals.iter().enumerate().skip(restart) {
        assert_eq!(s.objects.len(), 1, "frame {k}: {:?}", s.objects);
        assert_eq!(s.objects[0].id, other, "frame {k}");
        let reported = s.region.map(|r| r.track);
        if k < restart + config.confirm_frames - 1 {
            assert_eq!(reported, None, "frame {k}: the primary track's outputs wait as before");
        } else {
            assert_eq!(reported, Some(Some(other)), "frame {k}");
        }
    }
    for (k, s) in signals.iter().enumerate().skip(config.confirm_frames) {
        assert!(
            s.objects.iter().any(|o| o.id == other),
            "frame {k}: listed without a gap"
        );
    }
}

#[test]
fn a_moving_camera_lists_two_objects_from_the_compensated_difference() {
    // the camera creeps forward (its efference copy says so): the residual is the compensated
    // difference, which holds where each disc is and where it was; each track's box is cut to
    // where its disc is now (tracker §3)
    let mut d = Tracker::new(TrackerConfig {
        appearance: false,
        ..TrackerConfig::default()
    })
    .unwrap();
    let creeping = EfferenceCopy {
        forward_mps: 0.01,
        dt_s: 1.0 / 120.0,
        translation_m: [0.01 / 120.0, 0.0, 0.0],
        height_m: 0.35,
        ..EfferenceCopy::default()
    };
    let scene = |k: usize| {
        let t = k as f64;
        vec![
            Disc::new(30.0, 20.0 + 0.4 * t, 5.0, 0.1),
            Disc::new(62.0, 75.0 - 0.4 * t, 5.0, 0.9),
        ]
    };
    let signals: Vec<Signals> = (0..100)
        .map(|k| d.step_moving(&frame(&scene(k)), &creeping).unwrap())
        .collect();
    let ids = crossing_ids(&signals, &scene, 60);
    assert_ne!(ids.0, ids.1);
    for k in 60..100 {
        assert_eq!(crossing_ids(&signals, &scene, k), ids, "frame {k}");
        for disc in scene(k) {
            let o = nearest(&signals[k].objects, &disc);
            let c = disc.image_centre();
            let centre = [
                (o.region.x[0] + o.region.x[1]) / 2.0,
                (o.region.y[0] + o.region.y[1]) / 2.0,
            ];
            assert!(
                (centre[0] - c[0]).abs() < 1.5 * PIXEL && (centre[1] - c[1]).abs() < 1.5 * PIXEL,
                "frame {k}: box centre {centre:?} vs {c:?}"
            );
        }
    }
}
