//! The Principled BSDF's dielectric specular layer with Cycles' Fresnel, and the albedo
//! table over (roughness, cos θ, η) that layers the diffuse base under it.
//!
//! Cycles' Principled BSDF (`svm/closure.h`, `bsdf_microfacet.h`'s generalized Schlick with
//! a negative exponent) gives its specular layer the exact dielectric Fresnel's *shape* for
//! the layer's IOR η, rescaled to start at the layer's (tinted) F0:
//!
//! ```text
//! F(cos) = F0 + (1 − F0) s(cos, η),   s = clamp((F_η(cos) − F0_η) / (1 − F0_η), 0, 1)
//! ```
//! with F_η the unpolarised dielectric Fresnel and F0_η = ((η − 1)/(η + 1))². A large η
//! (Blender imports glTF's specular-glossiness with IOR 1000) keeps F at F0 up to the very
//! edge, where Schlick's (1 − cos)^5 rose to 1 for every F0. Specular IOR Level L scales
//! F0(IOR) by k = 2L and η becomes the IOR of that F0 (the shape follows), F90 stays 1.
//!
//! With multiple-scattering GGX (Blender's default) the layer's lobe is scaled, as Cycles'
//! `microfacet_ggx_preserve_energy`, by 1 + F_ms (1/E(μo) − 1): E the white GGX lobe's albedo,
//! F_ms = F_ss E_avg / (1 − F_ss (1 − E_avg)), F_ss = F0 + (1 − F0) s_avg(η) the
//! cosine-weighted mean Fresnel, s_avg computed here by quadrature of the exact Fresnel
//! (Cycles uses Kulla & Conty's fit of it).
//!
//! The diffuse base below is weighted by 1 − max over channels of the layer's albedo seen
//! from the viewer (Cycles' `closure_layering_weight`). The albedo is E_layer(μ) =
//! ms(μ) (F0 A + B), Fresnel being linear in F0: A = ∫ (1 − s) f cos, B = ∫ s f cos over
//! the single-scattering lobe of Fresnel 1 (A + B = E). [`LayerAlbedo`] tabulates (A, B) over
//! roughness, μ and z = F0_η^(1/4) (Cycles' parametrisation of η, which spends the nodes on
//! the common IORs 1–2), by stratified quadrature of the visible-normal estimator, built once
//! on first use. Cycles' own table stores the visible normals' unweighted mean of s and
//! multiplies E by it; the weighted split here is the lobe's exact albedo, so the white
//! furnace holds (a white base reflects exactly what the layer leaves it).
//!
//! An IOR below 1 (Cycles keeps a Principled IOR down to 1e-5; 0 is a near mirror) gives the
//! layer the Fresnel inside the denser medium: s = 1 beyond the critical angle (total internal
//! reflection), and s_avg of η < 1 for the compensation (its own row of the table, Cycles'
//! `fresnel_dielectric_Fss` fits the same mean). Cycles' albedo estimate, which weights the base,
//! reads its η > 1 table at z = √(|η − 1|/(η + 1)), the same z as 1/η: the shape of 1/η, which
//! reflects far less than η's at grazing angles. Caustic reads its table there too, as Cycles,
//! so a white furnace gains energy below 1 as Cycles' does (the exact albedo of η would weight
//! the base less than Cycles does; the agreement tests measure the base's brightness).

use super::albedo::{SpecularAlbedo, TABLE_N, build_entries};
use super::microfacet::{Ggx, fresnel_dielectric, reflect};
use glam::{Vec2, Vec3};

/// Normal-incidence reflectance of a dielectric of index `eta` in air.
#[inline]
pub fn f0_of(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// The IOR whose normal-incidence reflectance is `f0`; F0 is capped at 0.99 (η ≈ 399), as
/// Cycles' `ior_from_F0` caps it, so that η stays finite.
#[inline]
pub fn ior_from_f0(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 0.99).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// The layer's η for a material of index `ior` whose F0 is scaled by `k` (Cycles' 2 × Specular
/// IOR Level; glTF's specularFactor, which Blender imports as half the level): the IOR whose F0
/// is k F0(ior), below 1 when `ior` is (F0 is the same for η and 1/η; Cycles inverts it back).
/// An unscaled layer keeps `ior` itself (Cycles adjusts only when L ≠ 0.5).
#[inline]
pub fn layer_eta(ior: f32, k: f32) -> f32 {
    if k == 1.0 {
        return ior;
    }
    let eta = ior_from_f0(f0_of(ior) * k);
    if ior < 1.0 { 1.0 / eta } else { eta }
}

/// z = F0_η^(1/4) = √(|η − 1|/(η + 1)), the table's η axis: the same for η and 1/η, as
/// Cycles' (which reads its η > 1 table there for a layer of η < 1 too).
#[inline]
pub fn eta_z(eta: f32) -> f32 {
    ((eta - 1.0).abs() / (eta + 1.0)).sqrt()
}

/// The exact Fresnel's shape s(cos, η) rescaled to [0, 1] with F0_η = `f0_eta`. For η < 1
/// (Cycles keeps a Principled IOR below 1 down to 1e-5) the Fresnel is the one inside the
/// denser medium: s = 1 beyond the critical angle (total internal reflection).
#[inline]
pub fn fresnel_s(cos: f32, eta: f32, f0_eta: f32) -> f32 {
    if f0_eta >= 1.0 {
        return 0.0;
    }
    ((fresnel_dielectric(cos, eta) - f0_eta) / (1.0 - f0_eta)).clamp(0.0, 1.0)
}

/// Nodes of the table's z axis (uniform in z up to [`Z_MAX`]).
const Z_N: usize = 24;
/// The largest z tabulated: η = 1000 (F0 = 0.996), the IOR Blender gives specular-glossiness
/// materials; larger IORs read this node.
const Z_MAX: f32 = 0.999;
/// Stratified visible-normal samples per entry, per axis.
const STRATA: usize = 24;
/// Steps of the midpoint rule for s_avg over μ (its integrand is smooth, but for η < 1 at the
/// critical angle, where it is continuous: 1024 steps put its error far below 1e-5).
const AVG_STEPS: usize = 1024;

/// How far a table entry (A or B) may be from a fine quadrature, interpolation included
/// (asserted by the test below over points between the nodes); the layered BSDF's energy
/// tests allow for it.
pub const LAYER_TABLE_ERROR: f64 = 4e-3;

/// The layer's albedo split (A, B) over (roughness, μ, z), and s_avg over z for η > 1 and
/// for η < 1 (1/η at the same z).
pub struct LayerAlbedo {
    /// (A, B) per node, index ((z · TABLE_N) + roughness) · TABLE_N + μ.
    ab: Box<[[f32; 2]]>,
    /// Cosine-weighted mean of s per z node (η ≥ 1).
    s_avg: [f32; Z_N],
    /// Cosine-weighted mean of s per z node for the inverse index 1/η (total internal
    /// reflection included).
    s_avg_inv: [f32; Z_N],
}

/// η at node `k` of the z axis.
fn node_eta(k: usize) -> f32 {
    let z = Z_MAX * k as f32 / (Z_N - 1) as f32;
    let f0 = z * z * z * z;
    let s = f0.sqrt();
    (1.0 + s) / (1.0 - s)
}

impl LayerAlbedo {
    /// The table as shipped in `layer_table.rs`: the quadrature's own bits (the test
    /// `shipped_layer_table_is_the_computed_one` checks them and rewrites the file), so that a
    /// render does not spend 0.3-0.6 s of its start-up computing it (as Cycles ships its tables).
    fn shipped() -> Self {
        let bits = &super::layer_table::LAYER_AB_BITS;
        let ab: Vec<[f32; 2]> = bits.chunks_exact(2).map(|e| [f32::from_bits(e[0]), f32::from_bits(e[1])]).collect();
        let s_avg = super::layer_table::LAYER_S_AVG_BITS.map(f32::from_bits);
        let s_avg_inv = super::layer_table::LAYER_S_AVG_INV_BITS.map(f32::from_bits);
        LayerAlbedo { ab: ab.into_boxed_slice(), s_avg, s_avg_inv }
    }

    /// The table by quadrature (what `layer_table.rs` holds).
    #[cfg_attr(not(test), allow(dead_code))]
    fn compute() -> Self {
        let entries: Vec<[f32; 2]> = build_entries(Z_N * TABLE_N * TABLE_N, |i| {
            let (k, rest) = (i / (TABLE_N * TABLE_N), i % (TABLE_N * TABLE_N));
            let (ri, mi) = (rest / TABLE_N, rest % TABLE_N);
            let (a, b) = layer_split(SpecularAlbedo::mu(mi), ri as f32 / (TABLE_N - 1) as f32, node_eta(k), STRATA);
            [a, b]
        });
        let s_avg = std::array::from_fn(|k| fresnel_s_avg(node_eta(k)));
        let s_avg_inv = std::array::from_fn(|k| fresnel_s_avg(1.0 / node_eta(k)));
        LayerAlbedo { ab: entries.into_boxed_slice(), s_avg, s_avg_inv }
    }

    /// (A, B) at (μ, roughness, z), trilinear (μ along √μ, as the nodes).
    #[inline]
    pub fn ab(&self, mu: f32, roughness: f32, z: f32) -> (f32, f32) {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let w = z.clamp(0.0, Z_MAX) / Z_MAX * (Z_N - 1) as f32;
        // Through u32: the coordinates are clamped, and a float to u64 conversion costs a
        // dozen instructions more on x86-64 (this lookup runs once per BSDF view).
        let cell = |v: f32, n: usize| (v as u32 as usize).min(n - 2);
        let (x0, y0, w0) = (cell(x, TABLE_N), cell(y, TABLE_N), cell(w, Z_N));
        let (fx, fy, fw) = (x - x0 as f32, y - y0 as f32, w - w0 as f32);
        let t = &*self.ab;
        let mut out = [0.0f32; 2];
        for (dz, wz) in [(0, 1.0 - fw), (1, fw)] {
            let base = (w0 + dz) * TABLE_N * TABLE_N;
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                let row = base + (y0 + dy) * TABLE_N + x0;
                let (p0, p1) = (t[row], t[row + 1]);
                let k = wz * wy;
                out[0] += k * ((1.0 - fx) * p0[0] + fx * p1[0]);
                out[1] += k * ((1.0 - fx) * p0[1] + fx * p1[1]);
            }
        }
        (out[0], out[1])
    }

    /// The cosine-weighted mean of s for the layer of index `eta` (either side of 1), linear
    /// in z between the nodes.
    #[inline]
    pub fn s_avg(&self, eta: f32) -> f32 {
        let t = if eta < 1.0 { &self.s_avg_inv } else { &self.s_avg };
        let w = eta_z(eta).clamp(0.0, Z_MAX) / Z_MAX * (Z_N - 1) as f32;
        let w0 = (w as usize).min(Z_N - 2);
        let f = w - w0 as f32;
        t[w0] * (1.0 - f) + t[w0 + 1] * f
    }
}

/// (A, B) of the layer at μ = cos θo, roughness and η by `n`×`n` stratified visible-normal
/// samples of the estimator s · G2/G1 (B) and (1 − s) · G2/G1 (A).
pub fn layer_split(mu: f32, roughness: f32, eta: f32, n: usize) -> (f32, f32) {
    let ggx = Ggx::from_roughness(roughness);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let f0 = f0_of(eta);
    let (mut sa, mut sb) = (0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let m = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            let s = fresnel_s(wo.dot(m), eta, f0) as f64;
            let g = (ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
            sa += (1.0 - s) * g;
            sb += s * g;
        }
    }
    let k = (n * n) as f64;
    ((sa / k) as f32, (sb / k) as f32)
}

/// s_avg(η) = 2 ∫ s(μ, η) μ dμ by the midpoint rule.
pub fn fresnel_s_avg(eta: f32) -> f32 {
    let f0 = f0_of(eta);
    let mut sum = 0.0f64;
    for i in 0..AVG_STEPS {
        let mu = (i as f64 + 0.5) / AVG_STEPS as f64;
        sum += fresnel_s(mu as f32, eta, f0) as f64 * mu;
    }
    (2.0 * sum / AVG_STEPS as f64) as f32
}

/// The shared table, read from the shipped bits on first use.
pub fn layer_albedo() -> &'static LayerAlbedo {
    static TABLE: std::sync::OnceLock<LayerAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(LayerAlbedo::shipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::albedo::specular_albedo;

    /// The table between its nodes agrees with a 4× finer quadrature within
    /// [`LAYER_TABLE_ERROR`], at IORs between the z nodes (1.33, 1.5, 2.4, 1000).
    #[test]
    fn layer_table_accuracy() {
        let start = std::time::Instant::now();
        let t = layer_albedo();
        eprintln!("layer table built in {:?}", start.elapsed());
        let mut worst = 0.0f64;
        for &eta in &[1.33f32, 1.5, 2.4, 1000.0] {
            for &(mu, r) in &[(0.05f32, 0.1f32), (0.3, 0.5), (0.77, 0.23), (1.0, 1.0), (0.5, 0.05), (0.12, 0.83)] {
                let (a, b) = layer_split(mu, r, eta, 4 * STRATA);
                let (ta, tb) = t.ab(mu, r, eta_z(eta));
                let err = ((ta - a).abs().max((tb - b).abs())) as f64;
                worst = worst.max(err);
                assert!(err < LAYER_TABLE_ERROR, "η={eta} μ={mu} r={r}: table ({ta}, {tb}) vs ({a}, {b})");
            }
        }
        eprintln!("layer table: worst error {worst:.2e}");
    }

    /// The shipped table is the quadrature's, bit for bit; `CAUSTIC_TABLES_BLESS=1` rewrites
    /// `layer_table.rs` from the quadrature (then rebuild).
    #[test]
    fn shipped_layer_table_is_the_computed_one() {
        let computed = LayerAlbedo::compute();
        let ab: Vec<u32> = computed.ab.iter().flat_map(|e| [e[0].to_bits(), e[1].to_bits()]).collect();
        let avg: Vec<u32> = computed.s_avg.iter().map(|x| x.to_bits()).collect();
        let avg_inv: Vec<u32> = computed.s_avg_inv.iter().map(|x| x.to_bits()).collect();
        if std::env::var_os("CAUSTIC_TABLES_BLESS").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/layer_table.rs");
            std::fs::write(path, layer_table_source(&ab, &avg, &avg_inv)).expect("write layer_table.rs");
        }
        let shipped = &super::super::layer_table::LAYER_AB_BITS;
        assert_eq!(ab.len(), shipped.len());
        let differ = ab.iter().zip(shipped.iter()).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{differ} shipped entries differ from the quadrature: CAUSTIC_TABLES_BLESS=1 rewrites the file"
        );
        assert_eq!(avg.as_slice(), super::super::layer_table::LAYER_S_AVG_BITS.as_slice());
        assert_eq!(avg_inv.as_slice(), super::super::layer_table::LAYER_S_AVG_INV_BITS.as_slice());
    }

    fn layer_table_source(ab: &[u32], avg: &[u32], avg_inv: &[u32]) -> String {
        let words = |bits: &[u32]| -> String {
            bits.chunks(8)
                .map(|row| format!("    {}\n", row.iter().map(|b| format!("0x{b:08x},")).collect::<Vec<_>>().join(" ")))
                .collect()
        };
        format!(
            "//! The dielectric layer's albedo split (`fresnel_layer.rs`, `LayerAlbedo`) as its quadrature\n\
             //! computes it: (A, B) bit patterns over (z, roughness, √μ), 24 × 32 × 32 entries, and the\n\
             //! Fresnel shape's mean per z node, for η and for 1/η. Generated by\n\
             //! `CAUSTIC_TABLES_BLESS=1 cargo test --release --lib shipped_layer_table_is_the_computed_one`;\n\
             //! do not edit by hand.\n\n\
             /// (A, B) of each entry as `f32` bits.\n#[rustfmt::skip]\n\
             pub(super) static LAYER_AB_BITS: [u32; {}] = [\n{}];\n\n\
             /// s_avg per z node as `f32` bits.\n#[rustfmt::skip]\n\
             pub(super) static LAYER_S_AVG_BITS: [u32; {}] = [\n{}];\n\n\
             /// s_avg per z node for the index 1/η below 1 (total internal reflection included) as\n\
             /// `f32` bits.\n#[rustfmt::skip]\n\
             pub(super) static LAYER_S_AVG_INV_BITS: [u32; {}] = [\n{}];\n",
            ab.len(),
            words(ab),
            avg.len(),
            words(avg),
            avg_inv.len(),
            words(avg_inv)
        )
    }

    /// A + B is the white lobe's albedo, the same function the Schlick table's A + B is.
    #[test]
    fn split_sums_to_the_white_albedo() {
        let t = layer_albedo();
        for &(mu, r) in &[(0.2f32, 0.3f32), (0.9, 0.7), (0.5, 1.0)] {
            let (a, b) = t.ab(mu, r, eta_z(1.5));
            let e = specular_albedo().e_white(mu, r);
            assert!((a + b - e).abs() < 2.0 * LAYER_TABLE_ERROR as f32, "μ={mu} r={r}: {} vs {e}", a + b);
        }
    }

    /// The shape's limits: s(1) = 0 and s(0) = 1 (grazing incidence); η = 1000 keeps F at F0
    /// until within a few degrees of grazing (s < 0.05 at 85°), where Schlick's weight is 0.63;
    /// s_avg for IOR 1.5 is (F_avg − F0)/(1 − F0) with F_avg = 0.0918 the known hemispherical
    /// reflectance of glass (tabulated to three figures, so 1e-3).
    #[test]
    fn fresnel_shape() {
        for eta in [1.2f32, 1.5, 3.0, 1000.0] {
            let f0 = f0_of(eta);
            assert!(fresnel_s(1.0, eta, f0) < 1e-5);
            assert!(fresnel_s(0.0, eta, f0) > 1.0 - 1e-5, "η={eta}");
        }
        let c85 = 85f32.to_radians().cos();
        assert!(fresnel_s(c85, 1000.0, f0_of(1000.0)) < 0.05);
        let s_avg = fresnel_s_avg(1.5);
        let expect = (0.0918 - 0.04) / 0.96;
        assert!((s_avg - expect).abs() < 1e-3, "{s_avg} vs {expect}");
        assert!((layer_albedo().s_avg(1.5) - s_avg).abs() < 2e-3);
    }

    /// Specular IOR Level's η: k = 1 keeps the IOR; k scales F0; an IOR below 1 keeps its
    /// η below 1 (Cycles inverts the adjusted η back).
    #[test]
    fn level_rescales_f0() {
        assert_eq!(layer_eta(1.5, 1.0), 1.5);
        let eta = layer_eta(1.5, 0.5);
        assert!((f0_of(eta) - 0.02).abs() < 1e-6, "{eta}");
        assert!((layer_eta(1.5, 0.0) - 1.0).abs() < 1e-6);
        let eta = layer_eta(0.7, 0.5);
        assert!(eta < 1.0 && (f0_of(eta) - 0.5 * f0_of(0.7)).abs() < 1e-6, "{eta}");
        assert_eq!(layer_eta(0.7, 1.0), 0.7);
        assert_eq!(eta_z(0.5), eta_z(2.0));
    }

    /// The shape below 1: s(1) = 0, s = 1 beyond the critical angle (cos θ < √(1 − η²), total
    /// internal reflection) and below 1 just inside it; s_avg(η) by quadrature agrees with the
    /// identity 1 − F_avg(η) = η² (1 − F_avg(1/η)) between the hemispherical reflectances inside
    /// and outside (its two midpoint quadratures differ in form: 1e-4 covers the kink's
    /// O(h) error at 1024 steps), with Cycles' fit `fresnel_dielectric_Fss` for η < 1 (a fit:
    /// 5e-3), and the shipped row between its nodes within the η > 1 row's 2e-3.
    #[test]
    fn fresnel_shape_below_one() {
        for eta in [0.5f32, 0.7, 0.9, 1e-5] {
            let f0 = f0_of(eta);
            assert!(fresnel_s(1.0, eta, f0) < 1e-4, "η={eta}");
            let critical = (1.0 - eta * eta).sqrt();
            assert_eq!(fresnel_s(critical * 0.999, eta, f0), 1.0, "η={eta}");
            if eta > 0.1 {
                assert!(fresnel_s(critical * 1.01, eta, f0) < 1.0, "η={eta}");
            }
        }
        for eta in [0.5f32, 0.66, 0.8, 0.93] {
            let f0 = f0_of(eta);
            let f_out = f0 + (1.0 - f0) * fresnel_s_avg(1.0 / eta);
            let f_in = 1.0 - eta * eta * (1.0 - f_out);
            let expect = (f_in - f0) / (1.0 - f0);
            let s_avg = fresnel_s_avg(eta);
            assert!((s_avg - expect).abs() < 1e-4, "η={eta}: {s_avg} vs {expect}");
            let cycles_fss = 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607));
            assert!((f0 + (1.0 - f0) * s_avg - cycles_fss).abs() < 5e-3, "η={eta}: F_ss vs Cycles' {cycles_fss}");
            let table = layer_albedo().s_avg(eta);
            assert!((table - s_avg).abs() < 2e-3, "η={eta}: table {table} vs {s_avg}");
        }
    }
}
