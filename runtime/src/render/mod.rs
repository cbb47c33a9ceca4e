//! The renderers, one folder each over a shared core: [`iso`] (isosurfaces
//! by fixed steps or exact hits), [`dvr`] (direct volume rendering with
//! pre-integrated transfer functions), [`perm`] (Lim and Shin's cache on
//! top of DVR), [`pt`] (projected tetrahedra) and [`schemes`] (the
//! literature's hand-written BCC schemes, ray cast through DVR).

pub mod dvr;
pub mod iso;
pub mod perm;
pub mod pt;
pub mod schemes;
