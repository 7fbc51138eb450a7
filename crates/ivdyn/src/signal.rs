//! Signal conditioning: differentiation, filtering, resampling, decimation, outliers.
