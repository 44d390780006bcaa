//! Packing of the scene resources for the shaders, shared by every GPU backend: lamps, object
//! regions and intensity tables as rows of four 32-bit words. A backend only chooses the
//! container (a texture, a storage buffer); the rows are the same.
//!
//! - **Lamps** ([`lamp_rows`]): [`LAMP_ROWS`] rows per lamp: `(position.xyz, table index)`,
//!   the three rows of the world-to-photometric matrix `(xyz, 0)`, `(scale.rgb, 0)` (floats),
//!   then `(table offset, table width, table height, 0)` (unsigned integers; the offset is the
//!   table's first value in [`ies_values`]), then the luminous opening
//!   ([`crate::opening::OpeningParams`]) as floats: `(half.uvw, near)`, `(kind, axis, faces,
//!   size)` — all zero for a point lamp (no emitting faces).
//! - **Regions** ([`region_rows`]): two rows per object id (unsigned integers):
//!   `(layer, offset.x, offset.y, receiver ? 1 : 0)`, `(width, height, 0, 0)`; zero rows for
//!   non-receivers, which reflect nothing.
//! - **Intensity tables** ([`ies_values`]): every table's `width × height` candela values,
//!   row-major, each followed by its [`DensityProxy`]'s `PROXY_NODES²` values (so a lamp's
//!   proxy starts at its table's offset `+ width × height`), concatenated.

use crate::backend::{LampParams, SceneData};
use crate::layout::Region;
use crate::lightpaths::{DensityProxy, PROXY_NODES};

/// Rows of one packed lamp.
pub const LAMP_ROWS: usize = 8;

/// One packed lamp: five float rows, one integer row and two float rows (see the module
/// docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampRows {
    /// `(position.xyz, table index)`, the matrix rows `(xyz, 0)`, `(scale.rgb, 0)`.
    pub floats: [[f32; 4]; 5],
    /// `(table offset, table width, table height, 0)`.
    pub table: [u32; 4],
    /// The opening: `(half.uvw, near)`, `(kind, axis, faces, size)`.
    pub opening: [[f32; 4]; 2],
}

impl LampRows {
    /// All rows as 32-bit words (floats by their bits).
    pub fn words(&self) -> [u32; 4 * LAMP_ROWS] {
        let mut w = [0u32; 4 * LAMP_ROWS];
        for (i, v) in self.floats.iter().flatten().enumerate() {
            w[i] = v.to_bits();
        }
        w[20..24].copy_from_slice(&self.table);
        for (i, v) in self.opening.iter().flatten().enumerate() {
            w[24 + i] = v.to_bits();
        }
        w
    }

    /// All rows as floats (the integer row converted by value, as a float texture holds it).
    pub fn floats(&self) -> [[f32; 4]; LAMP_ROWS] {
        let mut r = [[0.0; 4]; LAMP_ROWS];
        r[..5].copy_from_slice(&self.floats);
        r[5] = self.table.map(|v| v as f32);
        r[6..].copy_from_slice(&self.opening);
        r
    }
}

/// The uploaded lamps, packed (a lamp whose table is missing gets an empty table).
pub fn lamp_rows(scene: &SceneData<'_>) -> Vec<LampRows> {
    let offsets = table_offsets(scene);
    scene
        .lamps
        .iter()
        .map(|l: &LampParams| {
            let (offset, size) = scene
                .ies_tables
                .get(l.table as usize)
                .map_or((0, [0, 0]), |t| {
                    (offsets[l.table as usize], [t.width, t.height])
                });
            let m = l.world_to_photometric;
            LampRows {
                floats: [
                    [l.position[0], l.position[1], l.position[2], l.table as f32],
                    [m[0][0], m[0][1], m[0][2], 0.0],
                    [m[1][0], m[1][1], m[1][2], 0.0],
                    [m[2][0], m[2][1], m[2][2], 0.0],
                    [l.scale[0], l.scale[1], l.scale[2], 0.0],
                ],
                table: [offset, size[0], size[1], 0],
                opening: l.opening.map_or([[0.0; 4]; 2], |o| {
                    [
                        [o.half[0], o.half[1], o.half[2], o.near],
                        [o.kind as f32, o.axis as f32, o.faces as f32, o.size],
                    ]
                }),
            }
        })
        .collect()
}

/// Two rows per object id (see the module docs).
pub fn region_rows(regions: &[Option<Region>]) -> Vec<[[u32; 4]; 2]> {
    regions
        .iter()
        .map(|r| match r {
            Some(r) => [
                [r.layer, r.offset[0], r.offset[1], 1],
                [r.size[0], r.size[1], 0, 0],
            ],
            None => [[0; 4]; 2],
        })
        .collect()
}

fn table_offsets(scene: &SceneData<'_>) -> Vec<u32> {
    let mut offsets = Vec::with_capacity(scene.ies_tables.len());
    let mut at = 0u32;
    for t in scene.ies_tables {
        offsets.push(at);
        at = at
            .saturating_add(t.width.saturating_mul(t.height))
            .saturating_add(PROXY_NODES * PROXY_NODES);
    }
    offsets
}

/// Every table's `width × height` values (short tables padded with zeros), each followed by
/// its [`DensityProxy`]'s values, concatenated.
pub fn ies_values(scene: &SceneData<'_>) -> Vec<f32> {
    let mut values = Vec::new();
    for t in scene.ies_tables {
        let n = (t.width as usize).saturating_mul(t.height as usize);
        let start = values.len();
        values.extend(t.values.iter().take(n));
        values.resize(start + n, 0.0);
        values.extend(DensityProxy::new(t).values);
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, TriangleAttributes, encode};
    use luxbake_ies::Photometry;

    #[test]
    fn lamps_regions_and_tables_pack_as_documented() {
        let tris = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
        let attrs = vec![TriangleAttributes {
            normals: [[0.0, 0.0, 1.0]; 3],
            uvs: [[0.0; 2]; 3],
            object: 0,
        }];
        let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("bvh");
        let enc = encode(&bvh, &tris, &attrs, &EncodeOptions::default()).expect("encode");
        let tables = vec![
            Photometry::isotropic(5.0).gpu_table(),
            Photometry::isotropic(7.0).gpu_table(),
        ];
        let lamp = LampParams {
            position: [1.0, 2.0, 3.0],
            world_to_photometric: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            scale: [0.5, 0.25, 2.0],
            table: 1,
            opening: None,
        };
        let regions = [
            None,
            Some(Region {
                layer: 2,
                offset: [3, 4],
                size: [5, 6],
            }),
        ];
        let bvh = crate::prepare::SceneBvh::new(enc);
        let scene = SceneData {
            bvh: &bvh,
            lamps: &[lamp],
            ies_tables: &tables,
            regions: &regions,
            layer_size: [8, 8],
            layers: 3,
            ray_epsilon: 1e-4,
            lamp_paths: &[],
        };
        let values = ies_values(&scene);
        let proxy = (PROXY_NODES * PROXY_NODES) as usize;
        let t0 = (tables[0].width * tables[0].height) as usize;
        let n0 = t0 + proxy;
        assert_eq!(
            values.len(),
            n0 + (tables[1].width * tables[1].height) as usize + proxy
        );
        // Each table, then its proxy.
        assert_eq!(values[..t0], tables[0].values[..]);
        assert_eq!(values[t0..n0], DensityProxy::new(&tables[0]).values[..]);
        assert_eq!(values[n0], tables[1].values[0]);
        assert_eq!(
            values[n0 + (tables[1].width * tables[1].height) as usize..],
            DensityProxy::new(&tables[1]).values[..]
        );
        let rows = lamp_rows(&scene);
        assert_eq!(rows[0].floats[0], [1.0, 2.0, 3.0, 1.0]);
        assert_eq!(rows[0].floats[4], [0.5, 0.25, 2.0, 0.0]);
        assert_eq!(
            rows[0].table,
            [n0 as u32, tables[1].width, tables[1].height, 0]
        );
        assert_eq!(rows[0].words()[20], n0 as u32);
        assert_eq!(rows[0].words()[0], 1.0f32.to_bits());
        assert_eq!(rows[0].floats()[5][1], tables[1].width as f32);
        assert_eq!(
            region_rows(&regions),
            vec![[[0; 4]; 2], [[2, 3, 4, 1], [5, 6, 0, 0]]]
        );
    }
}
