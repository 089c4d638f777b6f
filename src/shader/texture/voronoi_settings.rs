//! The Voronoi node's settings (`voronoi.rs`) as both the node and the per-dimension
//! coordinate types (`voronoi_coord.rs`) read them: apart, so neither file imports the other.

/// The node's "Feature" setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoronoiFeature {
    F1,
    F2,
    SmoothF1,
    DistanceToEdge,
    NSphereRadius,
}

/// The node's "Distance" setting (ignored in 1-D).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoronoiMetric {
    Euclidean,
    Manhattan,
    Chebychev,
    Minkowski,
}

/// The parameters after the node's clamping, as Cycles' `VoronoiParams`.
pub(super) struct Params {
    pub(super) feature: VoronoiFeature,
    pub(super) metric: VoronoiMetric,
    pub(super) normalize: bool,
    pub(super) scale: f32,
    pub(super) detail: f32,
    pub(super) roughness: f32,
    pub(super) lacunarity: f32,
    pub(super) smoothness: f32,
    pub(super) exponent: f32,
    pub(super) randomness: f32,
    pub(super) max_distance: f32,
    /// Compute the Color output (off when it is not linked: smooth F1 hashes a colour for
    /// each of its 125 cells).
    pub(super) color: bool,
}
