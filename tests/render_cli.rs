//! `loomlab render` on every shipped scene: PNG frames, a GIF and truth.csv come out; bad input exits 2.

use std::path::PathBuf;
use std::process::Command;

fn scenes() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join("scenes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    assert!(v.len() >= 3, "expected the example scenes in {}", dir.display());
    v
}

#[test]
fn render_writes_frames_gif_and_truth_for_every_scene() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render_cli");
    for scene in scenes() {
        let out = tmp.join(scene.file_stem().unwrap());
        let _ = std::fs::remove_dir_all(&out);
        let status = Command::new(env!("CARGO_BIN_EXE_loomlab"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--frames",
                "12",
                "--size",
                "64",
            ])
            .status()
            .unwrap();
        assert!(status.success(), "{}: {status}", scene.display());
        let frames = std::fs::read_dir(out.join("frames")).unwrap().count();
        assert_eq!(frames, 13, "{}: frames 0..=12", scene.display());
        let img = image::open(out.join("frames").join("frame_00012.png")).unwrap();
        assert_eq!((img.width(), img.height()), (64, 64));
        assert!(std::fs::metadata(out.join("view.gif")).unwrap().len() > 0);
        let csv = std::fs::read_to_string(out.join("truth.csv")).unwrap();
        let mut lines = csv.lines();
        assert!(lines.next().unwrap().starts_with("frame,t_s,robot_x_m"));
        assert!(lines.count() >= 13, "{}: one row per object per frame", scene.display());
    }
}

#[test]
fn render_rejects_unknown_keys_with_exit_code_2() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render_cli_bad");
    std::fs::create_dir_all(&tmp).unwrap();
    let bad = tmp.join("bad.toml");
    std::fs::write(&bad, "[world]\nsky_luminance = 0.5\ncolour = 3\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_loomlab"))
        .args([
            "render",
            bad.to_str().unwrap(),
            "--out",
            tmp.join("o").to_str().unwrap(),
            "--no-render",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("colour") && err.contains("bad.toml"), "{err}");
}
