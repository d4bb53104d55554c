//! Applying kernels to images: image I/O, the exact CPU reference and the
//! wgpu post-process (issue 5).
