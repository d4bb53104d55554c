//! The scene job (`ssskit scene`, `ssskit transmission`, and the scene
//! checks of compare and advise): kernels run through the screen-space
//! pass on a path-traced scene ([`compare`], results type
//! [`compare::SceneComparison`]), the light-space directional method
//! ([`directional`]), transmission ([`transmission`]), with the pass
//! ([`pass`]) and the per-region scoring ([`score`]) they share.

pub mod compare;
pub mod directional;
pub mod pass;
pub mod score;
pub mod transmission;
