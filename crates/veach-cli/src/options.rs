//! The options several subcommands share: strategies, heuristics, light selection and
//! sampling, samplers as clap values, and their library counterparts.

use clap::ValueEnum;
use veach::{Execution, Heuristic, LightSampling, LightSelection, Sampler, Strategy};

#[derive(Clone, Copy, ValueEnum)]
pub enum StrategyArg {
    /// Uniform hemisphere directions (pdf 1/2π)
    Uniform,
    /// glTF BRDF importance sampling
    Brdf,
    /// Light sampling: a point uniform on a light's area
    Light,
    /// Multiple importance sampling of light and BRDF samples
    Mis,
    /// MIS per BSDF lobe: the diffuse lobe by light samples alone (the BRDF samples too become
    /// light samples where there is no glossy lobe), the glossy lobe by MIS of light samples and
    /// samples of that lobe
    MisLobes,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum HeuristicArg {
    Balance,
    Power,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum LightSamplingArg {
    /// A point uniform on the light's area (pdf r² / (|cos θ_l| A)); a quad light through the linear map of the unit square
    Area,
    /// A direction uniform in the light's solid angle (pdf 1/Ω): a rectangle as a whole (Ureña 2013), other lights by triangle (Arvo 1995)
    SolidAngle,
    /// Spheres (round convex lights): a direction uniform in their bounding cone (pdf 1/Ω), traced to the light; other lights by area
    Cone,
    /// Each light by its shape: round lights by cone, rectangles by solid angle (Ureña 2013), others by area
    Auto,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum SamplerArg {
    /// Owen-scrambled Sobol points: each pixel's camera samples stratified (Burley 2020)
    Sobol,
    /// Independent uniform random numbers (plain Monte Carlo)
    Independent,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum SelectionArg {
    /// Sample every light (the estimator sums over lights)
    Each,
    /// One light per sample, chosen uniformly
    Uniform,
    /// One light per sample, chosen by emitted power
    Power,
    /// One light per sample, chosen per shading point: a quarter by power, three quarters by
    /// power times the BSDF towards the light (by power beyond 16 lights)
    Bsdf,
    /// One light per sample, chosen per shading point by the light tree (power, distance and
    /// orientation bounds; Conty Estevez & Kulla 2018)
    Tree,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ExecutionArg {
    Auto,
    Megakernel,
    Wavefront,
}

pub fn strategy_of(arg: StrategyArg) -> Strategy {
    match arg {
        StrategyArg::Uniform => Strategy::Uniform,
        StrategyArg::Brdf => Strategy::Brdf,
        StrategyArg::Light => Strategy::Light,
        StrategyArg::Mis => Strategy::Mis,
        StrategyArg::MisLobes => Strategy::MisLobes,
    }
}

pub fn heuristic_of(arg: HeuristicArg) -> Heuristic {
    match arg {
        HeuristicArg::Balance => Heuristic::Balance,
        HeuristicArg::Power => Heuristic::Power,
    }
}

pub fn light_sampling_of(arg: LightSamplingArg) -> LightSampling {
    match arg {
        LightSamplingArg::Area => LightSampling::Area,
        LightSamplingArg::SolidAngle => LightSampling::SolidAngle,
        LightSamplingArg::Cone => LightSampling::Cone,
        LightSamplingArg::Auto => LightSampling::Auto,
    }
}

pub fn sampler_of(arg: SamplerArg) -> Sampler {
    match arg {
        SamplerArg::Sobol => Sampler::Sobol,
        SamplerArg::Independent => Sampler::Independent,
    }
}

pub fn selection_of(arg: SelectionArg) -> LightSelection {
    match arg {
        SelectionArg::Each => LightSelection::Each,
        SelectionArg::Uniform => LightSelection::Uniform,
        SelectionArg::Power => LightSelection::Power,
        SelectionArg::Bsdf => LightSelection::Bsdf,
        SelectionArg::Tree => LightSelection::Tree,
    }
}

pub fn execution_of(arg: ExecutionArg) -> Execution {
    match arg {
        ExecutionArg::Auto => Execution::Auto,
        ExecutionArg::Megakernel => Execution::Megakernel,
        ExecutionArg::Wavefront => Execution::Wavefront,
    }
}
