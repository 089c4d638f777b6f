//! Precomputed directional albedos of the GGX reflection layer: the tables behind the
//! albedo scaling that layers the glTF material's diffuse base under its specular layer
//! (and its clear coat), built once, lazily, and immutable afterwards.
//!
//! E(μ, roughness, F0) = F0 · A(μ, roughness) + B(μ, roughness), Schlick's Fresnel being
//! linear in F0, so one table pair serves every F0; the cosine-weighted averages E_avg
//! come with it.

use super::microfacet::{Ggx, reflect, schlick_weight};
use glam::{Vec2, Vec3};

/// How far a table entry may be from a 4× finer quadrature (asserted by the tests below);
/// energy tests of the layered BSDF allow for it.
pub const TABLE_ERROR: f64 = 2e-3;

/// The entries f(0..n) of a lazily built table, on all cores unless called from a rayon
/// worker (a render tile): a worker waiting for its parallel jobs may steal other work, such
/// as another tile that needs the very table being built, and re-entering the OnceLock's
/// initialisation on the same thread deadlocks. Entries are independent, so both ways give
/// the same table.
pub(super) fn build_entries<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    use rayon::prelude::*;
    if rayon::current_thread_index().is_some() {
        (0..n).map(f).collect()
    } else {
        (0..n).into_par_iter().map(f).collect()
    }
}

/// Normal-incidence reflectance of the default dielectric layer (IOR 1.5).
pub const F0_DIELECTRIC: f32 = 0.04;

/// Resolution of the albedo table along cos θ and roughness.
pub(super) const TABLE_N: usize = 32;

/// Directional albedo of a GGX reflection layer with Schlick's Fresnel, as the split
/// E(μ, roughness, F0) = F0 · A(μ, roughness) + B(μ, roughness) (Schlick's Fresnel is
/// linear in F0), with the cosine-weighted averages of A and B. Computed once by
/// stratified quadrature of the VNDF estimator F · G2 / G1 (deterministic).
pub struct SpecularAlbedo {
    /// (A, B) side by side, row-major over (roughness, μ): a fixed size lets the
    /// compiler drop the bounds checks of the bilinear lookup, one of the hottest reads.
    ab: Box<[[f32; 2]; TABLE_N * TABLE_N]>,
    avg_a: Vec<f32>,
    avg_b: Vec<f32>,
}

/// Stratified samples per table entry (per axis); renders read the shipped table, so only
/// the tests that check and regenerate it run the quadrature.
#[cfg(test)]
const TABLE_STRATA: usize = 48;

impl SpecularAlbedo {
    /// The table by quadrature: 2.4 M GGX samples, ~0.13 s on two cores, which every
    /// render paid before its first sample (a third of a small benchmark render's wall
    /// time); renders read the shipped copy ([`Self::shipped`]) instead.
    #[cfg(test)]
    fn compute() -> Self {
        let entries: Vec<(f32, f32)> = build_entries(TABLE_N * TABLE_N, |i| {
            let (ri, mi) = (i / TABLE_N, i % TABLE_N);
            directional_albedo_split(Self::mu(mi), ri as f32 / (TABLE_N - 1) as f32, TABLE_STRATA)
        });
        Self::from_entries(&entries)
    }

    /// The table as shipped in `albedo_table.rs`: [`Self::compute`]'s entries bit for bit
    /// (the test `shipped_table_is_the_computed_one` checks it and rewrites the file), as
    /// Cycles ships its own precomputed tables.
    fn shipped() -> Self {
        let bits = &super::albedo_table::SPECULAR_AB_BITS;
        let entries: Vec<(f32, f32)> =
            bits.chunks_exact(2).map(|e| (f32::from_bits(e[0]), f32::from_bits(e[1]))).collect();
        Self::from_entries(&entries)
    }

    /// The table from its (A, B) entries, row-major over (roughness, μ), with the averages.
    fn from_entries(entries: &[(f32, f32)]) -> Self {
        let a: Vec<f32> = entries.iter().map(|e| e.0).collect();
        let b: Vec<f32> = entries.iter().map(|e| e.1).collect();
        // Averages 2 ∫ E(μ) μ dμ by the trapezoid rule on the table's nodes.
        let avg = |t: &[f32]| -> Vec<f32> {
            (0..TABLE_N)
                .map(|ri| {
                    let mut sum = 0.0f32;
                    for mi in 0..TABLE_N - 1 {
                        let (m0, m1) = (Self::mu(mi), Self::mu(mi + 1));
                        sum += 0.5 * (t[ri * TABLE_N + mi] * m0 + t[ri * TABLE_N + mi + 1] * m1) * (m1 - m0);
                    }
                    2.0 * sum
                })
                .collect()
        };
        let (avg_a, avg_b) = (avg(&a), avg(&b));
        let mut ab = Box::new([[0.0f32; 2]; TABLE_N * TABLE_N]);
        for (i, e) in entries.iter().enumerate() {
            ab[i] = [e.0, e.1];
        }
        SpecularAlbedo { ab, avg_a, avg_b }
    }

    /// Node i of the μ axis; nodes are spaced in √μ because E changes fastest at grazing angles.
    pub(super) fn mu(i: usize) -> f32 {
        let x = i as f32 / (TABLE_N - 1) as f32;
        (x * x).max(1e-3)
    }

    /// E(μ, roughness, F0), bilinear in the tables (one set of weights for both).
    #[inline]
    pub fn e(&self, mu: f32, roughness: f32, f0: f32) -> f32 {
        let (a, b) = self.ab(mu, roughness);
        f0 * a + b
    }

    /// (A, B) with E = F0·A + B, bilinear in the tables.
    #[inline]
    pub fn ab(&self, mu: f32, roughness: f32) -> (f32, f32) {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        // Through u32, as `LayerAlbedo::ab`: cheaper than a float to u64 conversion.
        let (x0, y0) = ((x as u32 as usize).min(TABLE_N - 2), (y as u32 as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (i00, i01) = (y0 * TABLE_N + x0, (y0 + 1) * TABLE_N + x0);
        let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
        let t = &*self.ab;
        let (p00, p10, p01, p11) = (t[i00], t[i00 + 1], t[i01], t[i01 + 1]);
        let at = |k: usize| w[0] * p00[k] + w[1] * p10[k] + w[2] * p01[k] + w[3] * p11[k];
        (at(0), at(1))
    }

    /// E of the GGX lobe without Fresnel (F = 1, Schlick's F0 = 1: A + B): the fraction a
    /// single-scattering microfacet surface reflects at all, which multiscatter GGX restores.
    #[inline]
    pub fn e_white(&self, mu: f32, roughness: f32) -> f32 {
        let (a, b) = self.ab(mu, roughness);
        a + b
    }

    /// Cosine-weighted average of [`e_white`](Self::e_white).
    #[inline]
    pub fn e_avg_white(&self, roughness: f32) -> f32 {
        let (a, b) = self.ab_avg(roughness);
        a + b
    }

    /// Cosine-weighted average of E over the hemisphere.
    #[inline]
    pub fn e_avg(&self, roughness: f32, f0: f32) -> f32 {
        let (a, b) = self.ab_avg(roughness);
        f0 * a + b
    }

    /// (A, B) of the cosine-weighted averages.
    #[inline]
    pub fn ab_avg(&self, roughness: f32) -> (f32, f32) {
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let y0 = (y as usize).min(TABLE_N - 2);
        let fy = y - y0 as f32;
        let lerp = |t: &[f32]| t[y0] * (1.0 - fy) + t[y0 + 1] * fy;
        (lerp(&self.avg_a), lerp(&self.avg_b))
    }
}

/// (A, B) of ∫ f_spec cos dωi = F0·A + B for the GGX layer at μ = cos θo, by `n`×`n`
/// stratified VNDF samples.
pub fn directional_albedo_split(mu: f32, roughness: f32, n: usize) -> (f32, f32) {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    albedo_split(&Ggx::from_roughness(roughness), wo, n)
}

/// (A, B) of the albedo of the GGX layer `ggx` seen from `wo`, by `n`×`n` stratified VNDF
/// samples of the estimator F · G2 / G1 with Schlick's F split linearly in F0.
pub(super) fn albedo_split(ggx: &Ggx, wo: Vec3, n: usize) -> (f32, f32) {
    let (mut sa, mut sb) = (0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let m = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            let w = schlick_weight(wo.dot(m));
            let g = (ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
            sa += (1.0 - w) as f64 * g;
            sb += w as f64 * g;
        }
    }
    let k = (n * n) as f64;
    ((sa / k) as f32, (sb / k) as f32)
}

/// ∫ f_spec cos dωi of the default (F0 = 0.04) layer.
pub fn directional_albedo(mu: f32, roughness: f32, n: usize) -> f32 {
    let (a, b) = directional_albedo_split(mu, roughness, n);
    F0_DIELECTRIC * a + b
}

/// The shared table.
pub fn specular_albedo() -> &'static SpecularAlbedo {
    static TABLE: std::sync::OnceLock<SpecularAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(SpecularAlbedo::shipped)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped table is the quadrature's, bit for bit. When the quadrature changes on
    /// purpose, `CAUSTIC_TABLES_BLESS=1` rewrites `albedo_table.rs` from it (then rebuild).
    #[test]
    fn shipped_table_is_the_computed_one() {
        let computed = SpecularAlbedo::compute();
        let bits: Vec<u32> = computed.ab.iter().flat_map(|e| [e[0].to_bits(), e[1].to_bits()]).collect();
        if std::env::var_os("CAUSTIC_TABLES_BLESS").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/albedo_table.rs");
            std::fs::write(path, table_source(&bits)).expect("write albedo_table.rs");
        }
        let shipped = SpecularAlbedo::shipped();
        let differ =
            bits.iter().zip(super::super::albedo_table::SPECULAR_AB_BITS.iter()).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{differ} shipped entries differ from the quadrature: CAUSTIC_TABLES_BLESS=1 rewrites the file"
        );
        assert_eq!(bits.len(), super::super::albedo_table::SPECULAR_AB_BITS.len());
        let avg_bits = |t: &SpecularAlbedo| t.avg_a.iter().chain(&t.avg_b).map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(avg_bits(&shipped), avg_bits(&computed));
    }

    /// `albedo_table.rs` for the entries' bits.
    fn table_source(bits: &[u32]) -> String {
        let mut s = String::from(
            "//! The GGX layer's albedo table (`albedo.rs`, `SpecularAlbedo`) as its quadrature computes it:\n\
             //! (A, B) bit patterns, row-major over (roughness, √μ), 32 × 32 entries. Generated by\n\
             //! `CAUSTIC_TABLES_BLESS=1 cargo test --release --lib shipped_table_is_the_computed_one`;\n\
             //! do not edit by hand.\n\n\
             /// (A, B) of each entry as `f32` bits.\n\
             #[rustfmt::skip]\n",
        );
        s += &format!("pub(super) const SPECULAR_AB_BITS: [u32; {}] = [\n", bits.len());
        for row in bits.chunks(8) {
            let words: Vec<String> = row.iter().map(|b| format!("0x{b:08x},")).collect();
            s += &format!("    {}\n", words.join(" "));
        }
        s += "];\n";
        s
    }

    /// The table agrees with a 4× finer quadrature within [`TABLE_ERROR`].
    #[test]
    fn albedo_table_accuracy() {
        let t = specular_albedo();
        for &(mu, r) in &[(0.05f32, 0.1f32), (0.3, 0.5), (0.77, 0.23), (1.0, 1.0), (0.5, 0.05)] {
            let fine = directional_albedo(mu, r, 4 * TABLE_STRATA) as f64;
            let err = (t.e(mu, r, F0_DIELECTRIC) as f64 - fine).abs();
            assert!(err < TABLE_ERROR, "E({mu}, {r}): table {} vs {fine}", t.e(mu, r, F0_DIELECTRIC));
        }
    }
}
