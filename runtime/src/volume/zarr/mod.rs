//! OME-Zarr images (0.4 on Zarr v2, 0.5 on Zarr v3; sharded or not; gzip,
//! zstd or blosc; u8, u16, i16 or f32 samples) read with the `zarrs` crates
//! as volumes, and written as pyramids (`pyramid.rs` over a store's plan,
//! `plan.rs`, and the writer's pieces, `write.rs`), of Cartesian samples or
//! of lattice samples stored as their cosets (`cosets.rs`).
//!
//! Reading is split by concern: `meta.rs` parses the `multiscales`
//! metadata into plain data, `store.rs` opens the store and each level's
//! array and checks them against the metadata, `source.rs` reads one
//! level, channel and time point box by box through a chunk cache
//! ([`BrickSource`](super::BrickSource)), so a store larger than host memory
//! is never read whole. With the `http` feature a store may be a URL
//! (`http.rs`: chunks fetched on demand, Range requests for shards).

mod cosets;
mod error;
#[cfg(feature = "http")]
mod http;
mod meta;
mod plan;
mod pyramid;
mod source;
mod store;
mod write;

pub use cosets::LatticeLayout;
pub use error::ZarrError;
#[cfg(feature = "http")]
pub use http::{HttpOptions, HttpStore};
pub use meta::{AxisKind, LevelMeta, Multiscale};
pub use plan::{pyramid_dims, StorePlan};
pub use pyramid::{write_lattice_pyramid, write_pyramid, LatticeOptions};
pub use source::{ZarrVolume, DEFAULT_CHUNK_CACHE};
pub use store::{is_store, OmeZarr, Selection, ZarrLevel};
pub use write::{PyramidOptions, PyramidReport, Reduction};

/// Sample types boxforge reads from and writes to Zarr arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZarrType {
    U8,
    U16,
    I16,
    F32,
}

impl ZarrType {
    /// The type's Zarr v3 name.
    pub fn name(self) -> &'static str {
        match self {
            ZarrType::U8 => "uint8",
            ZarrType::U16 => "uint16",
            ZarrType::I16 => "int16",
            ZarrType::F32 => "float32",
        }
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            ZarrType::U8 => 1,
            ZarrType::U16 | ZarrType::I16 => 2,
            ZarrType::F32 => 4,
        }
    }

    fn of(data_type: &zarrs::array::DataType) -> Option<ZarrType> {
        use zarrs::array::data_type::{Float32DataType, Int16DataType, UInt16DataType, UInt8DataType};
        if data_type.is::<UInt8DataType>() {
            Some(ZarrType::U8)
        } else if data_type.is::<UInt16DataType>() {
            Some(ZarrType::U16)
        } else if data_type.is::<Int16DataType>() {
            Some(ZarrType::I16)
        } else if data_type.is::<Float32DataType>() {
            Some(ZarrType::F32)
        } else {
            None
        }
    }
}
