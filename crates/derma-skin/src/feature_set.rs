//! Every placed feature of a run, kind by kind in the table's painting order
//! ([`crate::kinds::KINDS`]): what painting iterates over, and what reports count and list.

use crate::config::SkinConfig;
use crate::features::Feature;
use crate::field::FieldSet;
use crate::kinds::{KindEntry, KINDS};
use crate::placement::{PlacedKind, Placing, Scattered};
use crate::surface::Surface;
use crate::Result;
use serde::Serialize;

/// Every scattered feature, kind by kind in painting order.
#[derive(Default)]
pub struct FeatureSet {
    kinds: Vec<(&'static KindEntry, Box<dyn PlacedKind>)>,
}

impl FeatureSet {
    /// Adds a kind; kinds paint in the order they are added.
    pub fn push(&mut self, entry: &'static KindEntry, placed: Box<dyn PlacedKind>) {
        self.kinds.push((entry, placed));
    }

    /// The kinds in painting order.
    pub fn kinds(&self) -> impl Iterator<Item = (&'static KindEntry, &dyn PlacedKind)> {
        self.kinds.iter().map(|(e, k)| (*e, k.as_ref()))
    }

    /// The features of kind `name` as their type (`None` for another name or type).
    pub fn get<T: Feature + 'static>(&self, name: &str) -> Option<&Scattered<T>> {
        self.kinds
            .iter()
            .find(|(e, _)| e.name == name)
            .and_then(|(_, k)| k.as_any().downcast_ref())
    }

    /// Counts per kind, for reports.
    pub fn counts(&self) -> FeatureCounts {
        FeatureCounts(self.kinds.iter().map(|(e, k)| (*e, k.count())).collect())
    }

    /// Number of real features of every kind.
    pub fn total(&self) -> usize {
        self.kinds.iter().map(|(_, k)| k.count()).sum()
    }

    /// Every placed feature with its parameters (features.json).
    pub fn to_json(&self) -> serde_json::Value {
        let mut m = serde_json::Map::new();
        m.insert(
            "units".into(),
            "positions and lengths in mm on the surface".into(),
        );
        for (e, k) in &self.kinds {
            m.insert(e.name.into(), k.to_json());
        }
        serde_json::Value::Object(m)
    }
}

/// Features per kind, in painting order; serializes as a map from kind name to count.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureCounts(pub Vec<(&'static KindEntry, usize)>);

impl FeatureCounts {
    /// The count of kind `name` (0 for an unknown name).
    pub fn get(&self, name: &str) -> usize {
        self.0
            .iter()
            .find(|(e, _)| e.name == name)
            .map_or(0, |(_, n)| *n)
    }

    /// "5000 cysts, 700 moles, …" for a summary line.
    pub fn summary(&self) -> String {
        self.0
            .iter()
            .map(|(e, n)| format!("{n} {}", e.label))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl Serialize for FeatureCounts {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (e, n) in &self.0 {
            m.serialize_entry(e.name, n)?;
        }
        m.end()
    }
}

/// Places every kind of the table on `scatter_surface` (the surface at scatter resolution);
/// `size` is the output resolution, used for anti-aliasing sub-texel features.
pub fn place(
    cfg: &SkinConfig,
    fields: &FieldSet,
    scatter_surface: &Surface,
    size: usize,
) -> Result<FeatureSet> {
    let ctx = Placing {
        cfg,
        fields,
        surface: scatter_surface,
        size,
        scattered: Default::default(),
    };
    let mut set = FeatureSet::default();
    for entry in &KINDS {
        set.push(entry, (entry.place)(&ctx)?);
    }
    Ok(set)
}
