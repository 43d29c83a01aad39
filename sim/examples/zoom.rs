//! Upscales a PNG by an integer factor (nearest neighbour): `zoom IN.png OUT.png [factor]`.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let k: u32 = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(4);
    let img = image::open(&a[1])?.to_luma8();
    let out = image::imageops::resize(
        &img,
        img.width() * k,
        img.height() * k,
        image::imageops::FilterType::Nearest,
    );
    out.save(&a[2])?;
    Ok(())
}
