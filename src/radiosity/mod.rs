//! Radiosity (Bastos et al. §7, after \[2\] there: radiosity textures): the view-independent
//! diffuse light D, solved on lightmap texels and looked up by every other stage.

pub mod atlas;
pub mod back_sides;
pub mod batch;
pub mod contacts;
pub mod current;
mod disjoint;
mod dissection;
mod emitters;
pub mod format;
mod gather;
mod many_lights;
pub mod map;
mod mirror_lights;
mod next_event;
pub mod ray_cache;
pub use mirror_lights::{MIRROR_ROUGHNESS, is_mirror};
pub use transmission::MAX_LAYERS as MAX_GLASS_LAYERS;
mod seam_solve;
pub mod seams;
pub mod sides;
pub mod solve;
mod terms;
mod through_glass;
mod transmission;
mod transport;
mod varint;

pub use crate::settings::radiosity::{RadiosityOverride, RadiositySettings};
pub use current::{CurrentD, current_d, d_identity};
pub use map::RadiosityMap;
