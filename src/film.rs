//! The film: per-pixel accumulation of samples and AOVs, stored in tiles so that each
//! tile is owned by one worker at a time (no locks, no atomics per sample), and the
//! pixel filter, applied by importance sampling the filter as Cycles does: every sample
//! lands in one pixel with weight 1, so pixels are independent of each other — which
//! makes images identical for any thread count and crops equal to full-frame windows.
//!
//! Every sum is fixed point (`crate::fixed`): integer sums do not depend on the order of
//! the additions, so chunks of samples rendered apart and merged, or splat buffers of any
//! number of threads, give the single render's sums bit for bit.

use crate::cryptomatte::{self, Layout, Slot};
use crate::fixed::{add3, from_fixed, in_range, sum3, to_fixed};
use crate::math::Rgb;
use crate::passes::{Aov, CATCHER_SLOTS, FIRST_SAMPLE_SLOTS, Pass, PassSet, SPLAT_SLOTS, divide_even_color, slot};
use crate::scene::light_groups::GroupSums;
use crate::scene::shader_aovs::{AovSpec, AovSums};
use glam::{Vec2, Vec3};

mod filter;
pub use filter::Filter;

/// One camera sample's contributions to the film.
#[derive(Clone, Copy, Debug, Default)]
pub struct CameraSample {
    /// Radiance.
    pub radiance: Rgb,
    /// 1 when the path hit geometry (coverage), else 0.
    pub alpha: f32,
    /// The share of the sample a holdout took (a Holdout shader or a holdout object seen by
    /// the camera ray): Cycles keeps it out of alpha on an opaque film too.
    pub held: f32,
    /// Camera-space depth of the first hit (infinite when none).
    pub depth: f32,
    /// World-space shading normal of the first hit.
    pub normal: Vec3,
    /// Albedo of the first hit.
    pub albedo: Rgb,
    /// Values of the extra passes (`crate::passes`), filled only for the passes asked.
    pub aov: Aov,
    /// Cryptomatte ids of the first hit (object, material, asset; 0: none or not asked).
    pub crypto: [u32; 3],
    /// The radiance by light group (`crate::scene::light_groups`), filled only when asked.
    pub groups: GroupSums,
    /// The shader AOVs' values (`crate::scene::shader_aovs`), filled only when asked.
    pub shader_aovs: AovSums,
}

impl CameraSample {
    /// The sample of a panoramic camera's position outside its lens (`CameraRay::is_blind`):
    /// no light and opaque, as Cycles leaves a camera ray of length 0.
    pub fn blind() -> Self {
        CameraSample { alpha: 1.0, depth: f32::INFINITY, ..Default::default() }
    }

    /// Alpha under an opaque film (Film → Transparent off): the world counts as seen, so
    /// everything but the held-out share, as Cycles.
    pub fn make_opaque(&mut self) {
        self.alpha = 1.0 - self.held;
    }
}

/// True when the first hit's normal and albedo sums are read with `passes`: the Normal and
/// Denoising passes (a denoiser needs them too: the caller adds that).
pub fn needs_guides(passes: PassSet) -> bool {
    [Pass::Normal, Pass::DenoisingNormal, Pass::DenoisingAlbedo].into_iter().any(|p| passes.contains(p))
}

/// Sums for one pixel, fixed point (units of 2^-64, see `crate::fixed`).
#[derive(Clone, Copy, Debug)]
pub struct PixelAccum {
    /// Σ radiance (premultiplied by coverage).
    pub rgb: [i128; 3],
    /// Σ alpha.
    pub alpha: i128,
    /// Depth of the pixel's first sample (Cycles writes sample 0's, at the pixel centre).
    pub depth: f32,
    /// Σ normal.
    pub normal: [i128; 3],
    /// Σ albedo.
    pub albedo: [i128; 3],
    /// Samples taken.
    pub n: u32,
}

impl Default for PixelAccum {
    fn default() -> Self {
        PixelAccum { rgb: [0; 3], alpha: 0, depth: f32::INFINITY, normal: [0; 3], albedo: [0; 3], n: 0 }
    }
}

impl PixelAccum {
    /// Adds one camera sample; returns false (and adds nothing) when its radiance is not
    /// finite or beyond the fixed-point range.
    #[inline]
    pub fn add(&mut self, s: &CameraSample) -> bool {
        self.add_guided(s, true)
    }

    /// [`add`](Self::add), summing the normal and albedo only when `guides` (they are six
    /// of a sample's ten fixed-point conversions, which nothing reads unless a pass shows
    /// them or the denoiser takes them: [`needs_guides`]).
    #[inline]
    pub fn add_guided(&mut self, s: &CameraSample, guides: bool) -> bool {
        let rgb = s.radiance.to_array();
        if !in_range(rgb) {
            return false;
        }
        add3(&mut self.rgb, rgb);
        self.alpha = self.alpha.wrapping_add(to_fixed(s.alpha));
        if self.n == 0 {
            self.depth = s.depth;
        }
        if guides {
            add3(&mut self.normal, s.normal.to_array());
            add3(&mut self.albedo, s.albedo.to_array());
        }
        self.n += 1;
        true
    }

    /// Adds another accumulator of the same pixel (a merged chunk): sums add, depth is the
    /// first sample's (`o`'s when `o_first`: its samples come before this one's).
    pub fn merge(&mut self, o: &PixelAccum, o_first: bool) {
        sum3(&mut self.rgb, &o.rgb);
        self.alpha = self.alpha.wrapping_add(o.alpha);
        if (o_first && o.n > 0) || self.n == 0 {
            self.depth = o.depth;
        }
        sum3(&mut self.normal, &o.normal);
        sum3(&mut self.albedo, &o.albedo);
        self.n += o.n;
    }
}

/// A rectangle of pixels of the output image with its sums.
#[derive(Clone, Debug)]
pub struct Tile {
    /// Left column, in output-image pixels.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
    /// Row-major sums.
    pub pixels: Vec<PixelAccum>,
    /// The pixels sum the first hit's normal and albedo (else those sums stay zero).
    pub guides: bool,
    /// The [`slot`]s of the extra passes kept (bit mask; `PassSet::slots`).
    pub slots: u64,
    /// Row-major extra-pass sums, `slots.count_ones()` per pixel in slot order: fixed
    /// point, or for the first-sample slots the f32 bits of the pixel's first sample's value.
    pub extra: Vec<i128>,
    /// The Cryptomatte layers kept.
    pub crypto_layout: Layout,
    /// Row-major Cryptomatte slots, `crypto_layout.stride()` per pixel, layer after layer.
    pub crypto: Vec<Slot>,
    /// Samples whose Cryptomatte id went to a full pixel's last slot (an exact layout's
    /// list then no longer merges exactly; `Film::crypto_folded`).
    pub crypto_folded: u64,
    /// Light groups kept.
    pub groups: usize,
    /// Shader AOV channels kept.
    pub aov_channels: usize,
    /// Row-major light-group sums, fixed point, `3 × groups` per pixel, each pixel's
    /// followed by its `aov_channels` shader AOV sums ([`Tile::sums_stride`] in all).
    pub group_sums: Vec<i128>,
}

impl Tile {
    /// The light-group and shader AOV sums per pixel.
    #[inline]
    pub fn sums_stride(&self) -> usize {
        3 * self.groups + self.aov_channels
    }

    /// Adds one camera sample to pixel `i` of the tile (base sums and extra passes);
    /// returns false (and adds nothing) when a value is not finite or out of range.
    #[inline]
    pub fn add(&mut self, i: usize, s: &CameraSample) -> bool {
        if self.slots == 0 && self.crypto_layout.is_empty() && self.sums_stride() == 0 {
            return self.pixels[i].add_guided(s, self.guides);
        }
        let mut m = self.slots & !FIRST_SAMPLE_SLOTS;
        while m != 0 {
            if !in_range([s.aov.0[m.trailing_zeros() as usize], 0.0, 0.0]) {
                return false;
            }
            m &= m - 1;
        }
        if !s.groups.0[..self.groups].iter().all(|g| in_range(*g))
            || !s.shader_aovs.0[..self.aov_channels].iter().all(|v| in_range([*v, 0.0, 0.0]))
        {
            return false;
        }
        // Position and the indices are the pixel's first sample's, as Cycles' sample 0.
        let first = self.pixels[i].n == 0;
        if !self.pixels[i].add_guided(s, self.guides) {
            return false;
        }
        if !self.crypto_layout.is_empty() {
            let (layout, per) = (self.crypto_layout, self.crypto_layout.kept() as usize);
            let px = &mut self.crypto[i * layout.stride()..(i + 1) * layout.stride()];
            for (layer, kind) in px.chunks_exact_mut(per).zip(layout.iter()) {
                if !cryptomatte::add(layer, s.crypto[kind.index()]) {
                    self.crypto_folded += 1;
                }
            }
        }
        let stride = self.sums_stride();
        if stride > 0 {
            let (groups, aovs) = self.group_sums[i * stride..(i + 1) * stride].split_at_mut(3 * self.groups);
            for (acc, g) in groups.chunks_exact_mut(3).zip(&s.groups.0) {
                for (a, v) in acc.iter_mut().zip(g) {
                    *a = a.wrapping_add(to_fixed(*v));
                }
            }
            for (a, v) in aovs.iter_mut().zip(&s.shader_aovs.0) {
                *a = a.wrapping_add(to_fixed(*v));
            }
        }
        let stride = self.slots.count_ones() as usize;
        let acc = &mut self.extra[i * stride..(i + 1) * stride];
        let mut m = self.slots;
        for a in acc.iter_mut() {
            let k = m.trailing_zeros() as usize;
            if FIRST_SAMPLE_SLOTS >> k & 1 == 1 {
                if first {
                    *a = s.aov.0[k].to_bits() as i128;
                }
            } else {
                *a = a.wrapping_add(to_fixed(s.aov.0[k]));
            }
            m &= m - 1;
        }
        true
    }
}

/// Final pixel values of every pass, row-major, top row first.
#[derive(Clone, Debug, Default)]
pub struct FilmImage {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Combined RGBA (premultiplied).
    pub combined: Vec<[f32; 4]>,
    /// Camera-space depth (1e10 where nothing was hit, as Cycles).
    pub depth: Vec<f32>,
    /// Mean shading normal.
    pub normal: Vec<[f32; 3]>,
    /// Mean albedo.
    pub albedo: Vec<[f32; 3]>,
    /// Samples per pixel taken.
    pub samples: Vec<u32>,
    /// The Combined before denoising (`--denoise`; written as Cycles' Noisy Image), else empty.
    pub noisy: Vec<[f32; 4]>,
    /// The passes to write besides Combined (`crate::passes`).
    pub passes: PassSet,
    /// The extra passes' pixels, channels interleaved, for each written pass with a slot.
    pub extra: Vec<(Pass, Vec<f32>)>,
    /// Cryptomatte passes (`CryptoObject00`, ...) as r g b a interleaved: (id, coverage)
    /// of rank 2i and of rank 2i + 1.
    pub crypto: Vec<(String, Vec<f32>)>,
    /// EXR header attributes to write (the Cryptomatte manifests), key and text.
    pub metadata: Vec<(String, String)>,
    /// Per pixel, the means of the shadow catcher's sums (`slot::CATCHER_PASS` onward),
    /// when the film keeps them; `crate::shadow_catcher` turns them into Cycles' passes.
    pub catcher: Vec<[f32; CATCHER_SUMS]>,
    /// Each light group's mean radiance, RGB interleaved, in group order.
    pub light_groups: Vec<Vec<f32>>,
    /// The light groups' names, which the writer needs (the film knows only their number;
    /// the render sets them from the scene).
    pub light_group_names: Vec<String>,
    /// The shader AOVs' means, `channels` per pixel (each AOV's in the order of `aov_specs`).
    pub shader_aovs: Vec<f32>,
    /// The shader AOVs to write (names and kinds; the render sets them from the scene).
    pub aov_specs: Vec<AovSpec>,
}

/// Number of the shadow catcher's sums per pixel.
pub const CATCHER_SUMS: usize = slot::COUNT - slot::CATCHER_PASS;

/// Columns whose filter factor a splat computes once ([`SplatBuffer::add_filed`]): the
/// default 3-pixel Blackman-Harris spans 4; wider filters compute the rest per pixel.
const SPLAT_SPAN: usize = 8;

/// Depth written where no geometry was hit (Cycles' value).
pub const DEPTH_BACKGROUND: f32 = 1e10;

/// The whole output image as tiles.
#[derive(Clone, Debug)]
pub struct Film {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Tiles in scanline order of tiles.
    pub tiles: Vec<Tile>,
    /// Σ of light-tracing splats per pixel (bidirectional integrators), row-major, fixed point.
    pub splat: Vec<[i128; 3]>,
    /// Light paths traced: the splat sums' denominator (each light path estimates every pixel).
    pub light_paths: u64,
    /// Σ of the splats' light passes and light groups per pixel, row-major,
    /// `passes.splat_triples()` triples a pixel (`SplatBuffer::add_filed`); empty until a
    /// splat buffer that keeps them is drained, so integrators without splats pay nothing.
    pub splat_extra: Vec<[i128; 3]>,
    /// The passes asked for (which extra slots the tiles keep and what `image` gives).
    pub passes: PassSet,
}

/// A whole-window buffer of light-tracing splats owned by one worker at a time.
#[derive(Clone, Debug)]
pub struct SplatBuffer {
    /// Full-frame x of the window's left column.
    pub x0: u32,
    /// Full-frame y of the window's top row.
    pub y0: u32,
    /// Window width.
    pub w: u32,
    /// Window height.
    pub h: u32,
    /// Row-major sums, fixed point.
    pub data: Vec<[i128; 3]>,
    /// Splats added (for statistics).
    pub count: u64,
    /// Splat contributions dropped as non-finite or beyond the fixed-point range.
    pub dropped: u64,
    /// The light-pass slots kept ([`SPLAT_SLOTS`] of the asked passes).
    pub slots: u64,
    /// Light groups kept.
    pub groups: usize,
    /// Row-major sums of the light passes then the light groups, `triples` a pixel.
    pub extra: Vec<[i128; 3]>,
}

impl SplatBuffer {
    /// Adds `value` spread by the pixel filter around full-frame film position `pos`
    /// (pixels, from the top-left corner): each pixel gets value × filter(pos - centre).
    #[inline]
    pub fn add(&mut self, filter: &Filter, pos: Vec2, value: Vec3) {
        self.add_filed(filter, pos, value, &[], crate::scene::light_groups::NONE);
    }

    /// RGB triples kept per pixel besides Combined.
    #[inline]
    pub fn triples(&self) -> usize {
        self.slots.count_ones() as usize / 3 + self.groups
    }

    /// [`add`](Self::add), with the value's light-pass parts (`(slot, value)`, slots of
    /// `crate::passes::slot`; those not kept are skipped) and its light group.
    #[inline]
    pub fn add_filed(&mut self, filter: &Filter, pos: Vec2, value: Vec3, parts: &[(usize, Vec3)], group: u8) {
        let r = 0.5 * filter.width;
        let triples = self.triples();
        let group_at = ((group as usize) < self.groups).then(|| self.slots.count_ones() as usize / 3 + group as usize);
        let lo_x = (pos.x - r - 0.5).floor().max(self.x0 as f32) as i64;
        let hi_x = ((pos.x + r - 0.5).ceil() as i64).min(self.x0 as i64 + self.w as i64 - 1);
        let lo_y = (pos.y - r - 0.5).floor().max(self.y0 as f32) as i64;
        let hi_y = ((pos.y + r - 0.5).ceil() as i64).min(self.y0 as i64 + self.h as i64 - 1);
        // The filter is separable: each column's factor once, not once per pixel (the profile
        // of VCM on the Cornell box had the splats at 6 % of its instructions).
        let mut fx = [0.0f32; SPLAT_SPAN];
        let columns = (hi_x - lo_x + 1).clamp(0, SPLAT_SPAN as i64) as usize;
        for (k, f) in fx.iter_mut().enumerate().take(columns) {
            *f = filter.axis(pos.x - ((lo_x + k as i64) as f32 + 0.5));
        }
        for py in lo_y..=hi_y {
            let fy = filter.axis(pos.y - (py as f32 + 0.5));
            if fy == 0.0 {
                continue;
            }
            for px in lo_x..=hi_x {
                let k = (px - lo_x) as usize;
                let f = if k < SPLAT_SPAN { fx[k] } else { filter.axis(pos.x - (px as f32 + 0.5)) } * fy;
                if f > 0.0 {
                    let v = (value * f).to_array();
                    if !in_range(v) {
                        self.dropped += 1;
                        continue;
                    }
                    let i = (py - self.y0 as i64) as usize * self.w as usize + (px - self.x0 as i64) as usize;
                    add3(&mut self.data[i], v);
                    if triples == 0 {
                        continue;
                    }
                    let ex = &mut self.extra[i * triples..(i + 1) * triples];
                    for &(k, part) in parts {
                        let v = (part * f).to_array();
                        if self.slots >> k & 1 == 1 && in_range(v) {
                            add3(&mut ex[(self.slots & ((1u64 << k) - 1)).count_ones() as usize / 3], v);
                        }
                    }
                    if let Some(g) = group_at {
                        add3(&mut ex[g], v);
                    }
                }
            }
        }
        self.count += 1;
    }
}

/// Splat buffers handed to workers one per tile: a lock per tile, none per splat.
#[derive(Debug)]
pub struct SplatPool {
    free: std::sync::Mutex<Vec<SplatBuffer>>,
    window: [u32; 4],
    /// Light-pass slots and light groups the buffers keep.
    slots: u64,
    groups: usize,
}

impl SplatPool {
    /// A pool for the pixel window (x0, y0, x1, y1) of the full frame.
    pub fn new(window: [u32; 4]) -> Self {
        SplatPool { free: std::sync::Mutex::new(Vec::new()), window, slots: 0, groups: 0 }
    }

    /// A pool whose buffers also keep the light passes and light groups of `passes`.
    pub fn with_passes(window: [u32; 4], passes: PassSet) -> Self {
        SplatPool { slots: passes.slots() & SPLAT_SLOTS, groups: passes.light_groups(), ..Self::new(window) }
    }

    /// A buffer for one tile's work (a new one when all are in use).
    pub fn take(&self) -> SplatBuffer {
        let [x0, y0, x1, y1] = self.window;
        self.free.lock().map(|mut v| v.pop()).ok().flatten().unwrap_or_else(|| SplatBuffer {
            x0,
            y0,
            w: x1 - x0,
            h: y1 - y0,
            data: vec![[0; 3]; ((x1 - x0) * (y1 - y0)) as usize],
            count: 0,
            dropped: 0,
            slots: self.slots,
            groups: self.groups,
            extra: vec![
                [0; 3];
                ((x1 - x0) * (y1 - y0)) as usize * (self.slots.count_ones() as usize / 3 + self.groups)
            ],
        })
    }

    /// Returns a buffer after a tile.
    pub fn give(&self, b: SplatBuffer) {
        if let Ok(mut v) = self.free.lock() {
            v.push(b);
        }
    }

    /// Adds every buffer's sums to the film and clears them; returns the splats added and
    /// the splat contributions dropped.
    pub fn drain_into(&self, film: &mut Film) -> (u64, u64) {
        let (mut count, mut dropped) = (0, 0);
        if let Ok(mut v) = self.free.lock() {
            for b in v.iter_mut() {
                for (acc, d) in film.splat.iter_mut().zip(b.data.iter_mut()) {
                    sum3(acc, d);
                    *d = [0; 3];
                }
                if !b.extra.is_empty() {
                    if film.splat_extra.is_empty() {
                        film.splat_extra = vec![[0; 3]; b.extra.len()];
                    }
                    for (acc, d) in film.splat_extra.iter_mut().zip(b.extra.iter_mut()) {
                        sum3(acc, d);
                        *d = [0; 3];
                    }
                }
                count += b.count;
                dropped += b.dropped;
                b.count = 0;
                b.dropped = 0;
            }
        }
        (count, dropped)
    }
}

impl Film {
    /// An empty film cut into tiles of `tile` × `tile` pixels, with the passes Caustic
    /// wrote before pass selection (`PassSet::legacy`).
    pub fn new(width: u32, height: u32, tile: u32) -> Self {
        Self::with_passes(width, height, tile, PassSet::legacy())
    }

    /// An empty film keeping the sums that `passes` need.
    pub fn with_passes(width: u32, height: u32, tile: u32, passes: PassSet) -> Self {
        let slots = passes.slots();
        // The settings checked the levels (`resolve`); a set without Cryptomatte has none.
        let crypto_layout = passes.cryptomatte().unwrap_or_default();
        let stride = slots.count_ones() as usize;
        let groups = passes.light_groups();
        let aov_channels = passes.shader_aov_channels();
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(tile as usize) {
            for x0 in (0..width).step_by(tile as usize) {
                let (w, h) = (tile.min(width - x0), tile.min(height - y0));
                let n = (w * h) as usize;
                tiles.push(Tile {
                    x0,
                    y0,
                    w,
                    h,
                    pixels: vec![PixelAccum::default(); n],
                    guides: true,
                    slots,
                    extra: vec![0; n * stride],
                    crypto_layout,
                    crypto: vec![Slot::default(); n * crypto_layout.stride()],
                    crypto_folded: 0,
                    groups,
                    aov_channels,
                    group_sums: vec![0; n * (3 * groups + aov_channels)],
                });
            }
        }
        Film {
            width,
            height,
            tile_size: tile,
            tiles,
            splat: vec![[0; 3]; (width * height) as usize],
            light_paths: 0,
            splat_extra: Vec::new(),
            passes,
        }
    }

    /// Sums the first hit's normal and albedo (the default) or leaves them zero (`keep`
    /// false: for a render whose passes and denoiser do not read them, [`needs_guides`]).
    pub fn keep_guides(&mut self, keep: bool) {
        for t in &mut self.tiles {
            t.guides = keep;
        }
    }

    /// The sums of pixel (x, y) of the image.
    pub fn pixel(&self, x: u32, y: u32) -> &PixelAccum {
        let t = &self.tiles[self.tile_index(x, y)];
        &t.pixels[((y - t.y0) * t.w + x - t.x0) as usize]
    }

    /// The sums of pixel (x, y), mutable.
    pub fn pixel_mut(&mut self, x: u32, y: u32) -> &mut PixelAccum {
        let t = self.tile_index(x, y);
        let t = &mut self.tiles[t];
        &mut t.pixels[((y - t.y0) * t.w + x - t.x0) as usize]
    }

    /// The extra-pass sums of pixel (x, y): its kept slots (`PassSet::slots`, in slot order)
    /// and its light groups' sums (three per group) followed by its shader AOV sums.
    pub fn pixel_extra(&self, x: u32, y: u32) -> (&[i128], &[i128]) {
        let t = &self.tiles[self.tile_index(x, y)];
        let j = ((y - t.y0) * t.w + x - t.x0) as usize;
        let (stride, g) = (t.slots.count_ones() as usize, t.sums_stride());
        (&t.extra[j * stride..(j + 1) * stride], &t.group_sums[j * g..(j + 1) * g])
    }

    /// [`pixel_extra`](Self::pixel_extra), mutable.
    pub fn pixel_extra_mut(&mut self, x: u32, y: u32) -> (&mut [i128], &mut [i128]) {
        let t = self.tile_index(x, y);
        let t = &mut self.tiles[t];
        let j = ((y - t.y0) * t.w + x - t.x0) as usize;
        let (stride, g) = (t.slots.count_ones() as usize, t.sums_stride());
        (&mut t.extra[j * stride..(j + 1) * stride], &mut t.group_sums[j * g..(j + 1) * g])
    }

    /// Adds pixel (x, y) of `other`, a film of the same size and passes (a merged chunk):
    /// sums add; depth and the first-sample slots (Position, the indices) take `other`'s
    /// values when `other_first` (its samples come before this film's).
    pub fn merge_pixel(&mut self, x: u32, y: u32, other: &Film, other_first: bool) {
        self.pixel_mut(x, y).merge(other.pixel(x, y), other_first);
        let slots = self.passes.slots();
        let (a, ga) = self.pixel_extra_mut(x, y);
        let (b, gb) = other.pixel_extra(x, y);
        let mut m = slots;
        for (a, b) in a.iter_mut().zip(b) {
            let k = m.trailing_zeros();
            if FIRST_SAMPLE_SLOTS >> k & 1 == 0 {
                *a = a.wrapping_add(*b);
            } else if other_first {
                *a = *b;
            }
            m &= m - 1;
        }
        for (a, b) in ga.iter_mut().zip(gb) {
            *a = a.wrapping_add(*b);
        }
        self.merge_crypto(x, y, other, other_first);
    }

    /// Appends pixel (x, y)'s Cryptomatte list of `other` to this film's (before it when
    /// `other_first`): each kept in first-seen order with exact counts, so the later list's
    /// entries are counted after the earlier's, as the samples were (`cryptomatte::capped`).
    fn merge_crypto(&mut self, x: u32, y: u32, other: &Film, other_first: bool) {
        let t = self.tile_index(x, y);
        let layout = self.tiles[t].crypto_layout;
        if layout.is_empty() {
            return;
        }
        let per = layout.kept() as usize;
        let ot = &other.tiles[other.tile_index(x, y)];
        let oj = ((y - ot.y0) * ot.w + x - ot.x0) as usize;
        let theirs = &ot.crypto[oj * layout.stride()..(oj + 1) * layout.stride()];
        let tile = &mut self.tiles[t];
        let j = ((y - tile.y0) * tile.w + x - tile.x0) as usize;
        let mine = &mut tile.crypto[j * layout.stride()..(j + 1) * layout.stride()];
        tile.crypto_folded += cryptomatte::merge_lists(mine, theirs, per, other_first);
    }

    /// Samples whose Cryptomatte id was counted under another id (see `Tile::crypto_folded`).
    pub fn crypto_folded(&self) -> u64 {
        self.tiles.iter().map(|t| t.crypto_folded).sum()
    }

    /// Index of the tile holding (x, y): tiles are squares of `tile_size` in scanline order.
    fn tile_index(&self, x: u32, y: u32) -> usize {
        let per_row = self.width.div_ceil(self.tile_size);
        ((y / self.tile_size) * per_row + x / self.tile_size) as usize
    }

    /// Normalises every pixel by its own sample count.
    pub fn image(&self) -> FilmImage {
        let n = (self.width * self.height) as usize;
        let mut img = FilmImage {
            width: self.width,
            height: self.height,
            combined: vec![[0.0; 4]; n],
            depth: vec![DEPTH_BACKGROUND; n],
            normal: vec![[0.0; 3]; n],
            albedo: vec![[0.0; 3]; n],
            samples: vec![0; n],
            noisy: Vec::new(),
            passes: self.passes,
            extra: self
                .passes
                .iter()
                .filter(|p| p.slot().is_some())
                .map(|p| (p, vec![0.0; n * p.channels().len()]))
                .collect(),
            crypto: Vec::new(),
            metadata: Vec::new(),
            catcher: match self.passes.slots() & CATCHER_SLOTS {
                0 => Vec::new(),
                _ => vec![[0.0; CATCHER_SUMS]; n],
            },
            light_groups: vec![vec![0.0; n * 3]; self.passes.light_groups()],
            light_group_names: Vec::new(),
            shader_aovs: vec![0.0; n * self.passes.shader_aov_channels()],
            aov_specs: Vec::new(),
        };
        let layout = self.tiles.first().map(|t| t.crypto_layout).unwrap_or_default();
        for kind in layout.iter() {
            for name in layout.pass_names(kind) {
                img.crypto.push((name, vec![0.0; n * 4]));
            }
        }
        let mut ranked = vec![Slot::default(); layout.slots as usize];
        let kept = layout.kept() as usize;
        for t in &self.tiles {
            for ty in 0..t.h {
                for tx in 0..t.w {
                    let p = &t.pixels[(ty * t.w + tx) as usize];
                    let i = ((t.y0 + ty) * self.width + t.x0 + tx) as usize;
                    img.samples[i] = p.n;
                    if p.n == 0 {
                        continue;
                    }
                    let inv = 1.0 / p.n as f64;
                    let mean = |s: &[i128; 3]| s.map(|v| (from_fixed(v) * inv) as f32);
                    let mut c = p.rgb.map(|v| from_fixed(v) * inv);
                    if self.light_paths > 0 {
                        for (c, s) in c.iter_mut().zip(self.splat[i]) {
                            *c += from_fixed(s) / self.light_paths as f64;
                        }
                    }
                    img.combined[i] = [c[0] as f32, c[1] as f32, c[2] as f32, (from_fixed(p.alpha) * inv) as f32];
                    if p.depth.is_finite() {
                        img.depth[i] = p.depth;
                    }
                    img.normal[i] = mean(&p.normal);
                    img.albedo[i] = mean(&p.albedo);
                    let stride = t.slots.count_ones() as usize;
                    let j = (ty * t.w + tx) as usize;
                    let acc = &t.extra[j * stride..(j + 1) * stride];
                    // This pixel's splat sums of light passes and groups (bidirectional).
                    let triples = self.passes.splat_triples();
                    let splats = match self.splat_extra.is_empty() || self.light_paths == 0 {
                        true => &[][..],
                        false => &self.splat_extra[i * triples..(i + 1) * triples],
                    };
                    // Splat sums in the units of the camera samples' sums (n samples; the
                    // splats' mean is over the light paths).
                    let to_sums = p.n as f64 / self.light_paths.max(1) as f64;
                    let splat_slots = self.passes.slots() & SPLAT_SLOTS;
                    let splat_at = |k: usize| -> f64 {
                        if splats.is_empty() || splat_slots >> k & 1 == 0 {
                            return 0.0;
                        }
                        let before = (splat_slots & ((1u64 << k) - 1)).count_ones() as usize;
                        from_fixed(splats[before / 3][before % 3]) * to_sums
                    };
                    extra_pixel(&mut img.extra, i, t.slots, acc, inv, &splat_at);
                    let sums = &t.group_sums[j * t.sums_stride()..(j + 1) * t.sums_stride()];
                    let (groups, aovs) = sums.split_at(3 * t.groups);
                    let group_splats = splats.get(splat_slots.count_ones() as usize / 3..).unwrap_or(&[]);
                    for (g, (data, sum)) in img.light_groups.iter_mut().zip(groups.chunks_exact(3)).enumerate() {
                        for (c, (d, v)) in data[i * 3..i * 3 + 3].iter_mut().zip(sum).enumerate() {
                            let splat = group_splats.get(g).map_or(0.0, |s| from_fixed(s[c]) * to_sums);
                            *d = ((from_fixed(*v) + splat) * inv) as f32;
                        }
                    }
                    let c = t.aov_channels;
                    for (d, v) in img.shader_aovs[i * c..(i + 1) * c].iter_mut().zip(aovs) {
                        *d = (from_fixed(*v) * inv) as f32;
                    }
                    if let Some(c) = img.catcher.get_mut(i) {
                        for (k, v) in c.iter_mut().enumerate() {
                            let at = slot::CATCHER_PASS + k;
                            // The matte's splats (bidirectional integrators) join its sums.
                            let sum =
                                from_fixed(acc[(t.slots & ((1u64 << at) - 1)).count_ones() as usize]) + splat_at(at);
                            *v = (sum * inv) as f32;
                        }
                    }
                    let per = layout.slots as usize;
                    let px = &t.crypto[j * layout.stride()..(j + 1) * layout.stride()];
                    for (l, layer) in px.chunks_exact(kept.max(1)).enumerate() {
                        // An exact list (chunks) holds what a render keeping `per` slots would.
                        cryptomatte::capped(layer, &mut ranked);
                        cryptomatte::rank(&mut ranked);
                        for (pair, slot) in ranked.chunks_exact(2).enumerate() {
                            let out = &mut img.crypto[l * per / 2 + pair].1[i * 4..i * 4 + 4];
                            for (k, s) in slot.iter().enumerate() {
                                out[2 * k] = f32::from_bits(s.id);
                                out[2 * k + 1] = (s.count as f64 * inv) as f32;
                            }
                        }
                    }
                }
            }
        }
        img
    }
}

/// The extra passes' values of pixel `i` from its sums `acc` (one per slot of `slots`, in
/// slot order) and 1 / its sample count.
fn extra_pixel(
    out: &mut [(Pass, Vec<f32>)],
    i: usize,
    slots: u64,
    acc: &[i128],
    inv: f64,
    splat: &dyn Fn(usize) -> f64,
) {
    let at = |k: usize| acc[(slots & ((1u64 << k) - 1)).count_ones() as usize];
    // A slot's sum over the camera samples plus what light-tracing splats add to it.
    let sum = |k: usize| from_fixed(at(k)) + splat(k);
    let mean = |k: usize| (sum(k) * inv) as f32;
    for (pass, data) in out.iter_mut() {
        let Some(k) = pass.slot() else { continue };
        let c = pass.channels().len();
        let px = &mut data[i * c..(i + 1) * c];
        match pass.divided_by() {
            // Direct and Indirect are read divided by their Colour pass, as Cycles reads them.
            Some(col) => {
                let cs = col.slot().unwrap_or(k);
                let sum3 = |k: usize| [0, 1, 2].map(|d| sum(k + d) as f32);
                px.copy_from_slice(&divide_even_color(sum3(k), sum3(cs)));
            }
            None if *pass == Pass::AmbientOcclusion => px.fill(mean(k)),
            None => {
                for (d, v) in px.iter_mut().enumerate() {
                    *v = if FIRST_SAMPLE_SLOTS >> (k + d) & 1 == 1 {
                        f32::from_bits(at(k + d) as u32)
                    } else {
                        mean(k + d)
                    };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A film that keeps no guides sums the same radiance, alpha and depth and leaves the
    /// normal and albedo at zero; the default keeps them.
    #[test]
    fn guides_are_summed_only_when_kept() {
        let s = CameraSample {
            radiance: Vec3::new(0.25, 0.5, 2.0),
            alpha: 1.0,
            depth: 3.0,
            normal: Vec3::new(0.0, 0.6, 0.8),
            albedo: Vec3::new(0.8, 0.7, 0.1),
            ..Default::default()
        };
        let mut kept = Film::with_passes(2, 2, 2, PassSet::default());
        let mut skipped = Film::with_passes(2, 2, 2, PassSet::default());
        skipped.keep_guides(false);
        assert!(kept.tiles[0].add(1, &s) && skipped.tiles[0].add(1, &s));
        let (a, b) = (kept.pixel(1, 0), skipped.pixel(1, 0));
        assert_eq!((a.rgb, a.alpha, a.depth.to_bits(), a.n), (b.rgb, b.alpha, b.depth.to_bits(), b.n));
        assert_eq!(a.normal, [0, to_fixed(0.6), to_fixed(0.8)]);
        assert_eq!(a.albedo, [to_fixed(0.8), to_fixed(0.7), to_fixed(0.1)]);
        assert_eq!((b.normal, b.albedo), ([0; 3], [0; 3]));
        assert!(needs_guides(PassSet::legacy()) && !needs_guides(PassSet::default()));
    }

    /// Depth is the pixel's first sample's, as Cycles' sample 0, not the nearest: a nearer
    /// later sample leaves it, and a merge takes the earlier chunk's whichever is nearer.
    #[test]
    fn depth_is_the_first_samples() {
        let at = |depth| CameraSample { depth, ..Default::default() };
        let mut film = Film::with_passes(1, 1, 1, PassSet::default());
        assert!(film.tiles[0].add(0, &at(5.0)) && film.tiles[0].add(0, &at(2.0)));
        assert_eq!(film.pixel(0, 0).depth, 5.0);
        let mut missed = PixelAccum::default();
        assert!(missed.add(&at(f32::INFINITY)) && missed.add(&at(1.0)));
        assert_eq!(missed.depth, f32::INFINITY, "a first sample that hit nothing keeps the background");
        let (mut later, earlier) = (*film.pixel(0, 0), missed);
        later.merge(&earlier, true);
        assert_eq!(later.depth, f32::INFINITY);
        let mut first = *film.pixel(0, 0);
        first.merge(&missed, false);
        assert_eq!(first.depth, 5.0);
        let filter = filter::Filter::blackman_harris(1.5);
        assert_eq!(filter.camera_offset(0, Vec2::new(0.1, 0.9)), Vec2::ZERO);
        assert_eq!(filter.camera_offset(1, Vec2::new(0.1, 0.9)), filter.sample(Vec2::new(0.1, 0.9)));
    }

    /// The sampled offsets follow the Blackman-Harris profile: the centre bin is about
    /// as dense as the formula says relative to a bin near the edge.
    #[test]
    fn blackman_harris_sampling_matches_profile() {
        let f = Filter::blackman_harris(1.5);
        let n = 200_000;
        let mut hist = [0u32; 15];
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32;
            let x = f.sample(Vec2::new(u, 0.5)).x;
            assert!(x.abs() <= 0.75 + 1e-4);
            hist[(((x / 1.5) + 0.5) * 15.0).min(14.0) as usize] += 1;
        }
        let bh = |x: f32| {
            let v = std::f32::consts::TAU * x;
            0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos()
        };
        // Expected mass of a bin: the profile integrated over it (midpoint rule, fine).
        let mass = |b: usize| (0..100).map(|k| bh((b as f32 + (k as f32 + 0.5) / 100.0) / 15.0)).sum::<f32>();
        let ratio = hist[7] as f32 / hist[2] as f32;
        let expect = mass(7) / mass(2);
        // The sampled density is the profile tabulated in 256 steps: 1% is its error.
        assert!((ratio / expect - 1.0).abs() < 0.01, "{ratio} vs {expect}");
    }

    #[test]
    fn tiles_cover_image_once() {
        let film = Film::new(70, 33, 32);
        let covered: u32 = film.tiles.iter().map(|t| t.w * t.h).sum();
        assert_eq!(covered, 70 * 33);
    }
}
