//! Converts the Combined pass of a Caustic EXR to an sRGB PNG for viewing:
//! `cargo run --release --example exr_to_png -- IN.exr OUT.png [EXPOSURE_STOPS]`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: exr_to_png IN.exr OUT.png [EXPOSURE_STOPS]");
        std::process::exit(2);
    }
    let scale = 2f32.powf(args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(0.0));
    let (w, h, px) = caustic::output::read_combined(std::path::Path::new(&args[1]))?;
    let encode = |c: f32| {
        let c = (c * scale).clamp(0.0, 1.0);
        let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0 + 0.5) as u8
    };
    let mut img = image::RgbaImage::new(w as u32, h as u32);
    for (i, p) in px.iter().enumerate() {
        img.put_pixel((i % w) as u32, (i / w) as u32, image::Rgba([encode(p[0]), encode(p[1]), encode(p[2]), 255]));
    }
    img.save(&args[2])?;
    let mean: f32 = px.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).sum::<f32>() / px.len() as f32;
    println!("{w}x{h}, mean {mean:.5}");
    Ok(())
}
