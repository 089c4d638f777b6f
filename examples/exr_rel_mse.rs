//! Relative mean squared error of images against a reference, for equal-time
//! comparisons of integrators: `cargo run --release --example exr_rel_mse -- REF.exr A.exr [B.exr ...]`.
//! Per pixel and channel (c - r)² / (r² + 10⁻²) (the 10⁻² keeps black pixels from
//! dominating, as in the rendering literature), averaged over the image.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: exr_rel_mse REF.exr IMAGE.exr [IMAGE.exr ...]");
        std::process::exit(2);
    }
    let load = |p: &str| caustic::output::read_combined(std::path::Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let (w, h, reference) = load(&args[0]);
    for p in &args[1..] {
        let (w2, h2, img) = load(p);
        assert_eq!((w, h), (w2, h2), "{p}: size differs from the reference");
        let mut sum = 0.0f64;
        for (a, r) in img.iter().zip(&reference) {
            for c in 0..3 {
                let (a, r) = (a[c] as f64, r[c] as f64);
                sum += (a - r).powi(2) / (r * r + 1e-2);
            }
        }
        println!("{p}: relative MSE {:.4e}", sum / (3 * w * h) as f64);
    }
}
