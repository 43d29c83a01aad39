//! Tests of video input (`loomlab_detector::video`).

use std::path::Path;

use image::codecs::gif::GifEncoder;
use image::{Delay, GrayImage, ImageBuffer, Luma, Rgb, RgbImage, Rgba, RgbaImage};
use loomlab_detector::video::{Video, load_video};
use loomlab_detector::{DetectorError, NonSquare};

fn gray(w: u32, h: u32, v: u8) -> GrayImage {
    GrayImage::from_pixel(w, h, Luma([v]))
}

fn load(path: &Path) -> Video {
    load_video(path, NonSquare::Embed).unwrap_or_else(|e| panic!("{e}"))
}

fn io_error(path: &Path) -> String {
    match load_video(path, NonSquare::Embed) {
        Ok(v) => panic!("expected an error, got {} frames", v.len()),
        Err(e @ DetectorError::Io { .. }) => e.to_string(),
        Err(e) => panic!("wrong error variant: {e:?}"),
    }
}

#[test]
fn directory_frames_load_in_natural_order() {
    let dir = tempfile::tempdir().unwrap();
    // Written out of order; f10 must come after f2.
    for (name, v) in [("f10.png", 100u8), ("f2.png", 20), ("f1.png", 10), ("f03.png", 30)] {
        gray(8, 8, v).save(dir.path().join(name)).unwrap();
    }
    // Ignored: other files and subdirectories.
    std::fs::write(dir.path().join("README.txt"), "not a frame").unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    gray(8, 8, 255).save(dir.path().join("sub/f0.png")).unwrap();

    let v = load(dir.path());
    assert_eq!(v.len(), 4);
    assert_eq!(v.frame_size(), 8);
    assert_eq!(v.fps, None);
    assert_eq!(v.source, dir.path());
    let first: Vec<f32> = v.frames.iter().map(|f| f.get(3, 3)).collect();
    let expected: Vec<f32> = [10u8, 20, 30, 100].iter().map(|&x| x as f32 / 255.0).collect();
    for (a, b) in first.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-6, "{first:?} vs {expected:?}");
    }
}

#[test]
fn pixel_positions_and_colour_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let mut img = RgbImage::from_pixel(4, 4, Rgb([0, 0, 0]));
    img.put_pixel(3, 1, Rgb([255, 255, 255])); // x = 3 (column), y = 1 (row)
    img.put_pixel(0, 2, Rgb([128, 128, 128]));
    img.save(dir.path().join("0.png")).unwrap();
    let f = &load(dir.path()).frames[0];
    assert!((f.get(1, 3) - 1.0).abs() < 1e-6);
    assert!((f.get(2, 0) - 128.0 / 255.0).abs() < 1e-3);
    assert_eq!(f.get(0, 0), 0.0);
}

#[test]
fn sixteen_bit_png_keeps_precision() {
    let dir = tempfile::tempdir().unwrap();
    let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_pixel(4, 4, Luma([1000u16]));
    let path = dir.path().join("deep.png");
    img.save(&path).unwrap();
    let v = load(&path);
    assert_eq!(v.len(), 1);
    assert!((v.frames[0].get(0, 0) - 1000.0 / 65535.0).abs() < 1e-6);
}

#[test]
fn jpeg_frames_load() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..3u8 {
        RgbImage::from_pixel(16, 16, Rgb([200, 200, 200]))
            .save(dir.path().join(format!("frame_{k}.jpg")))
            .unwrap();
    }
    let v = load(dir.path());
    assert_eq!(v.len(), 3);
    assert!((v.frames[2].get(8, 8) - 200.0 / 255.0).abs() < 0.02);
}

#[test]
fn non_square_frames_are_embedded_or_cropped() {
    let dir = tempfile::tempdir().unwrap();
    gray(6, 4, 255).save(dir.path().join("a.png")).unwrap(); // 6 wide, 4 high
    let e = load_video(dir.path(), NonSquare::Embed).unwrap();
    assert_eq!(e.frame_size(), 6);
    assert_eq!(e.frames[0].get(0, 0), 0.5); // padding row
    assert_eq!(e.frames[0].get(1, 0), 1.0);
    let c = load_video(dir.path(), NonSquare::Crop).unwrap();
    assert_eq!(c.frame_size(), 4);
    assert!(c.frames[0].data().iter().all(|&v| v == 1.0));
}

#[test]
fn animated_gif_loads_with_frame_rate() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clip.gif");
    {
        let file = std::fs::File::create(&path).unwrap();
        let mut enc = GifEncoder::new(file);
        let frames = [0u8, 128, 255].map(|v| {
            image::Frame::from_parts(
                RgbaImage::from_pixel(10, 10, Rgba([v, v, v, 255])),
                0,
                0,
                Delay::from_numer_denom_ms(50, 1),
            )
        });
        enc.encode_frames(frames).unwrap();
    }
    let v = load(&path);
    assert_eq!(v.len(), 3);
    assert_eq!(v.frame_size(), 10);
    let fps = v.fps.expect("GIF delays give a frame rate");
    assert!((fps - 20.0).abs() < 1e-9, "fps {fps}");
    let centre: Vec<f32> = v.frames.iter().map(|f| f.get(5, 5)).collect();
    assert!(
        centre[0] < 0.01 && (centre[1] - 128.0 / 255.0).abs() < 0.02 && centre[2] > 0.99,
        "{centre:?}"
    );
}

#[test]
fn single_image_is_a_one_frame_video() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("still.PNG");
    gray(5, 5, 51).save_with_format(&path, image::ImageFormat::Png).unwrap();
    let v = load(&path);
    assert_eq!(v.len(), 1);
    assert!((v.frames[0].get(2, 2) - 0.2).abs() < 1e-6);
}

#[test]
fn missing_path_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope");
    let msg = io_error(&missing);
    assert!(msg.contains("nope"), "{msg}");
}

#[test]
fn empty_directory_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
    let msg = io_error(dir.path());
    assert!(msg.contains("no PNG/JPEG frames"), "{msg}");
}

#[test]
fn undecodable_frame_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    gray(4, 4, 0).save(dir.path().join("1.png")).unwrap();
    std::fs::write(dir.path().join("2.png"), b"this is not a png").unwrap();
    let msg = io_error(dir.path());
    assert!(msg.contains("2.png") && msg.contains("decode"), "{msg}");
    // Same for a broken GIF.
    let gif = dir.path().join("broken.gif");
    std::fs::write(&gif, b"GIF89a garbage").unwrap();
    let msg = io_error(&gif);
    assert!(msg.contains("broken.gif"), "{msg}");
}

#[test]
fn frames_of_different_sizes_are_an_error() {
    let dir = tempfile::tempdir().unwrap();
    gray(4, 4, 0).save(dir.path().join("1.png")).unwrap();
    gray(5, 4, 0).save(dir.path().join("2.png")).unwrap();
    let msg = io_error(dir.path());
    assert!(
        msg.contains("2.png") && msg.contains("1.png") && msg.contains("same size"),
        "{msg}"
    );
}

#[test]
fn unsupported_file_type_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clip.mp4");
    std::fs::write(&path, b"\0\0\0").unwrap();
    let msg = io_error(&path);
    assert!(msg.contains("clip.mp4") && msg.contains("ffmpeg"), "{msg}");
}

#[test]
fn a_frame_copied_into_another_equals_its_source() {
    // `clone_from` reuses the destination's buffer, whatever its size and invalid-pixel count
    let source = loomlab_detector::Frame::from_f32(3, vec![0.1, f32::NAN, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]).unwrap();
    let mut copy = loomlab_detector::Frame::uniform(5, 0.5);
    copy.clone_from(&source);
    assert_eq!(copy, source);
    assert_eq!((copy.n(), copy.invalid_pixels()), (3, 1));
    assert_eq!(source.clone(), source);
}
