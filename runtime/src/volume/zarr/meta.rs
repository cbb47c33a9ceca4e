//! An OME-Zarr image's `multiscales` metadata (0.4 on Zarr v2, 0.5 on
//! Zarr v3) parsed with `ome_zarr_metadata` and reduced to the plain data
//! the reader needs: the axes, and per level its array path and its
//! physical scale along z, y, x. The checks a renderer depends on (three
//! space axes last, a scale per level that grows from level to level) are
//! made here, before any array is opened.

use super::ZarrError;
use ome_zarr_metadata::v0_4::{Axis, AxisType, CoordinateTransform, CoordinateTransformScale};
use ome_zarr_metadata::AnyOmeFields;
use std::path::Path;

/// What an axis of the image's arrays is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// `t`: time points.
    Time,
    /// `c`: channels.
    Channel,
    /// A spatial axis (the last three are z, y, x).
    Space,
}

/// One resolution level: the array's path inside the store and the
/// physical size of one voxel along (z, y, x).
#[derive(Clone, Debug, PartialEq)]
pub struct LevelMeta {
    pub path: String,
    pub scale_zyx: [f64; 3],
}

/// The first multiscale image of a store, as the reader uses it.
#[derive(Clone, Debug, PartialEq)]
pub struct Multiscale {
    /// "0.4" or "0.5".
    pub version: String,
    /// The kind of each array axis, in the arrays' order (space last).
    pub axes: Vec<AxisKind>,
    /// The axes' names (for messages).
    pub axis_names: Vec<String>,
    /// Level 0 (finest) first.
    pub levels: Vec<LevelMeta>,
    /// The space axes' unit, where all three give the same one.
    pub space_unit: Option<String>,
}

impl Multiscale {
    /// Parses a group's attributes (`.zattrs` of a v2 group, the
    /// `attributes` of a v3 `zarr.json`).
    pub fn from_attributes(
        store: &Path,
        attributes: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Multiscale, ZarrError> {
        let bad = |reason: String| ZarrError::Metadata { path: store.to_path_buf(), reason };
        if !attributes.contains_key("ome") && !attributes.contains_key("multiscales") {
            return Err(ZarrError::NotOme { path: store.to_path_buf() });
        }
        let fields: AnyOmeFields = serde_json::from_value(serde_json::Value::Object(attributes.clone()))
            .map_err(|e| bad(format!("its OME metadata does not parse ({e})")))?;
        let version = fields.version();
        let (axes, datasets, global) = match fields {
            AnyOmeFields::V0_4(a) => {
                let m = a
                    .multiscales
                    .and_then(|m| m.into_iter().next())
                    .ok_or(ZarrError::NotOme { path: store.to_path_buf() })?;
                let sets: Vec<_> = m.datasets.into_iter().map(|d| (d.path, d.coordinate_transformations)).collect();
                (m.axes, sets, m.coordinate_transformations)
            }
            AnyOmeFields::V0_5(f) => {
                let m = f
                    .multiscales
                    .and_then(|m| m.into_iter().next())
                    .ok_or(ZarrError::NotOme { path: store.to_path_buf() })?;
                let sets: Vec<_> = m.datasets.into_iter().map(|d| (d.path, d.coordinate_transformations)).collect();
                (m.axes, sets, m.coordinate_transformations)
            }
        };
        let kinds = axis_kinds(store, &axes)?;
        if datasets.is_empty() {
            return Err(bad("its multiscales list no dataset (level)".into()));
        }
        let global = match &global {
            Some(t) => scale_of(t, axes.len()).map_err(bad)?,
            None => None,
        };
        let mut levels = Vec::with_capacity(datasets.len());
        for (path, transforms) in datasets {
            let own = scale_of(&transforms, axes.len())
                .map_err(|r| bad(format!("level '{path}': {r}")))?
                .unwrap_or_else(|| vec![1.0; axes.len()]);
            let all: Vec<f64> = match &global {
                Some(g) => own.iter().zip(g).map(|(a, b)| a * b).collect(),
                None => own,
            };
            let n = all.len();
            let scale_zyx = [all[n - 3], all[n - 2], all[n - 1]];
            if scale_zyx.iter().any(|s| !s.is_finite() || *s <= 0.0) {
                return Err(bad(format!("level '{path}' has a non-positive or non-finite scale {scale_zyx:?}")));
            }
            levels.push(LevelMeta { path, scale_zyx });
        }
        for pair in levels.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            if (0..3).any(|i| b.scale_zyx[i] < a.scale_zyx[i] * (1.0 - 1e-6)) {
                return Err(ZarrError::LevelOrder {
                    path: store.to_path_buf(),
                    coarser: b.path.clone(),
                    finer_scale: a.scale_zyx,
                    coarser_scale: b.scale_zyx,
                });
            }
        }
        let units: Vec<Option<String>> = axes[axes.len() - 3..]
            .iter()
            .map(|a| a.unit.as_ref().and_then(|u| serde_json::to_value(u).ok()?.as_str().map(str::to_string)))
            .collect();
        let space_unit = units[0].clone().filter(|_| units.iter().all(|u| *u == units[0]));
        Ok(Multiscale {
            version,
            axes: kinds,
            axis_names: axes.iter().map(|a| a.name.clone()).collect(),
            levels,
            space_unit,
        })
    }
}

/// The kinds of `axes`: at most one time and one channel axis, then exactly
/// three space axes, last (the order OME-Zarr 0.4 and 0.5 prescribe).
fn axis_kinds(store: &Path, axes: &[Axis]) -> Result<Vec<AxisKind>, ZarrError> {
    let kinds: Vec<AxisKind> = axes
        .iter()
        .map(|a| match (&a.r#type, a.name.as_str()) {
            (Some(AxisType::Space), _) => AxisKind::Space,
            (Some(AxisType::Time), _) => AxisKind::Time,
            (Some(AxisType::Channel), _) => AxisKind::Channel,
            (_, "x" | "y" | "z") => AxisKind::Space,
            (_, "t") => AxisKind::Time,
            _ => AxisKind::Channel,
        })
        .collect();
    let space = kinds.iter().filter(|k| **k == AxisKind::Space).count();
    let n = kinds.len();
    let space_last = n >= 3 && kinds[n - 3..].iter().all(|k| *k == AxisKind::Space);
    let once = |k: AxisKind| kinds.iter().filter(|x| **x == k).count() <= 1;
    if space != 3 || !space_last || !once(AxisKind::Time) || !once(AxisKind::Channel) {
        return Err(ZarrError::Axes { path: store.to_path_buf(), axes: axes.iter().map(|a| a.name.clone()).collect() });
    }
    Ok(kinds)
}

/// The scale of a list of coordinate transformations (None: no scale).
fn scale_of(transforms: &[CoordinateTransform], rank: usize) -> Result<Option<Vec<f64>>, String> {
    for t in transforms {
        if let CoordinateTransform::Scale(s) = t {
            return match s {
                CoordinateTransformScale::List { scale } if scale.len() == rank => {
                    Ok(Some(scale.iter().map(|&v| f64::from(v)).collect()))
                }
                CoordinateTransformScale::List { scale } => {
                    Err(format!("a scale of {} values for {rank} axes", scale.len()))
                }
                CoordinateTransformScale::Path { path } => {
                    Err(format!("a scale stored in a file ({}), which boxforge does not read", path.display()))
                }
            };
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(json: &str) -> Result<Multiscale, ZarrError> {
        let v: serde_json::Value = serde_json::from_str(json).unwrap();
        Multiscale::from_attributes(Path::new("s.zarr"), v.as_object().unwrap())
    }

    const V05: &str = r#"{"ome": {"version": "0.5", "multiscales": [{
        "axes": [{"name": "c", "type": "channel"}, {"name": "z", "type": "space"},
                 {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
        "datasets": [
          {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 2, 1, 1]}]},
          {"path": "1", "coordinateTransformations": [{"type": "scale", "scale": [1, 4, 2, 2]}]}]}]}}"#;

    #[test]
    fn reads_axes_and_scales_of_0_5() {
        let m = parse(V05).unwrap();
        assert_eq!(m.version, "0.5");
        assert_eq!(m.axes, [AxisKind::Channel, AxisKind::Space, AxisKind::Space, AxisKind::Space]);
        assert_eq!(m.levels[0], LevelMeta { path: "0".into(), scale_zyx: [2.0, 1.0, 1.0] });
        assert_eq!(m.levels[1].scale_zyx, [4.0, 2.0, 2.0]);
    }

    #[test]
    fn reads_0_4_with_a_global_scale() {
        let json = r#"{"multiscales": [{"version": "0.4",
            "axes": [{"name": "z", "type": "space"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
            "datasets": [{"path": "s0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 1]}]}],
            "coordinateTransformations": [{"type": "scale", "scale": [3, 0.5, 0.5]}]}]}"#;
        let m = parse(json).unwrap();
        assert_eq!(m.version, "0.4");
        assert_eq!(m.levels, [LevelMeta { path: "s0".into(), scale_zyx: [3.0, 0.5, 0.5] }]);
    }

    #[test]
    fn refuses_a_coarser_level_with_a_finer_scale() {
        let swapped = V05.replace("[1, 4, 2, 2]", "[1, 1, 2, 2]");
        assert!(matches!(parse(&swapped), Err(ZarrError::LevelOrder { .. })), "{:?}", parse(&swapped));
    }

    #[test]
    fn refuses_two_space_axes_and_plain_zarr() {
        let two = V05.replace(r#"{"name": "z", "type": "space"}"#, r#"{"name": "t", "type": "time"}"#);
        let e = parse(&two).unwrap_err();
        assert!(matches!(e, ZarrError::Axes { .. }), "{e}");
        assert!(matches!(parse(r#"{"foo": 1}"#), Err(ZarrError::NotOme { .. })));
    }
}
