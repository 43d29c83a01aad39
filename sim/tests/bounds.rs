//! The simulator's bounds: the smallest camera frame (the detectors' minimum) and the episode cap.

use loomlab_sim::{MAX_EPISODE_FRAMES, MIN_FRAME_SIZE, WorldDesc, episode_frames};

#[test]
fn min_frame_size_is_the_detectors() {
    assert_eq!(MIN_FRAME_SIZE as usize, loomlab_detector::MIN_FRAME_SIZE);
}

#[test]
fn camera_rejects_frames_smaller_than_the_detectors_take() {
    let mut w = WorldDesc::empty();
    for n in [0, 1, 8, MIN_FRAME_SIZE - 1] {
        w.camera.n = n;
        let e = w.validate().unwrap_err().to_string();
        assert!(
            e.contains("world.camera.n") && e.contains(&format!("= {n}:")) && e.contains("20..=2048"),
            "{e}"
        );
    }
    w.camera.n = MIN_FRAME_SIZE;
    w.validate().unwrap();
}

#[test]
fn episode_cap_is_one_hour_at_the_default_camera_rate() {
    let w = WorldDesc::empty();
    assert_eq!(
        episode_frames("episode.duration_s", 3600.0, w.dt()).unwrap(),
        MAX_EPISODE_FRAMES
    );
    let e = episode_frames("episode.duration_s", 3600.5, w.dt())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("episode.duration_s = 3600.5:") && e.contains("432000"),
        "{e}"
    );
}
