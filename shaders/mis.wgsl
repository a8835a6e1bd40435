// mis.wgsl: multiple importance sampling weights with the sample counts in them.
// Veach & Guibas, "Optimally Combining Sampling Techniques for Monte Carlo Rendering",
// SIGGRAPH 1995, §4: balance heuristic w_f = n_f p_f / sum_k n_k p_k, and the power heuristic
// with exponent beta = 2: w_f = (n_f p_f)^2 / sum_k (n_k p_k)^2.

fn balance_heuristic(n_f: f32, pdf_f: f32, n_g: f32, pdf_g: f32) -> f32 {
    let f = n_f * pdf_f;
    let g = n_g * pdf_g;
    if f <= 0.0 {
        return 0.0;
    }
    return 1.0 / (1.0 + g / f);
}

fn power_heuristic(n_f: f32, pdf_f: f32, n_g: f32, pdf_g: f32) -> f32 {
    let f = n_f * pdf_f;
    let g = n_g * pdf_g;
    if f <= 0.0 {
        return 0.0;
    }
    // Divided through by f to stay finite when f * f would overflow.
    let r = g / f;
    return 1.0 / (1.0 + r * r);
}

// Weight of a sample of strategy f (n_f samples, pdf_f) against strategy g.
fn mis_weight(n_f: f32, pdf_f: f32, n_g: f32, pdf_g: f32) -> f32 {
    if frame.heuristic == HEURISTIC_POWER {
        return power_heuristic(n_f, pdf_f, n_g, pdf_g);
    }
    return balance_heuristic(n_f, pdf_f, n_g, pdf_g);
}
