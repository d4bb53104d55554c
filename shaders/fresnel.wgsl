// Unpolarised Fresnel reflectance at a dielectric interface, relative index
// eta = n_t / n_i; 1 under total internal reflection (fresnel_dielectric in
// src/profile/fresnel.rs). Shared by the Monte Carlo tracer (mc_trace.wgsl)
// and the light-space pass (light_space.wgsl); the host prepends it.
fn fresnel(cos_in: f32, eta: f32) -> f32 {
    if (eta == 1.0) {
        return 0.0;
    }
    let cos_i = clamp(cos_in, 0.0, 1.0);
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}
