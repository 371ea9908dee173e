//! Small numerical building blocks shared by the models.

pub mod quadrature;
pub mod roots;
pub mod special;
pub mod stats;
pub mod tiled_pairs;

/// Whether the processor has AVX: the pair kernels then take their AVX forms, whose results
/// are the bits of their portable twins.
pub fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
