// ---- grain_porosity_read.wgsl: porosity(i), Robinson eq. (9), from the solid fraction
// grain_solid_fraction left for the window (grain_porosity.wgsl). ----

@group(0) @binding(16) var<storage, read> solid: array<u32>;

fn porosity(i: u32) -> f32 {
    return 1.0 - f32(solid[i]) * (1.0 / 2147483648.0);
}
