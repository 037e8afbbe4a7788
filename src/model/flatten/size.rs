//! The geometry a glTF scene expands to, counted from its accessors before
//! anything is baked ([`expanded_size`]): every triangle primitive of every
//! mesh as often as the scene places it (its nodes, and the copies of
//! `EXT_mesh_gpu_instancing`), so a small file that places a large mesh many
//! times is refused before its vertices are allocated, and the vertex buffer
//! is allocated once at its final size.

use std::collections::HashMap;

use super::check::check_accessor;
use crate::model::{MAX_NODE_DEPTH, MAX_NODE_VISITS};

/// Vertices and triangle-list indices (strips and fans counted as the lists
/// they become).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(in crate::model) struct Size {
    pub(in crate::model) vertices: u64,
    pub(in crate::model) indices: u64,
}

impl Size {
    fn plus(self, other: Size, times: u64) -> Size {
        Size {
            vertices: (self.vertices).saturating_add(other.vertices.saturating_mul(times)),
            indices: (self.indices).saturating_add(other.indices.saturating_mul(times)),
        }
    }
}

/// The size of the scene the flattener bakes (the default scene, else the
/// first, else every mesh once). Accessors that do not fit their buffers
/// count nothing, and `None` comes back for a node graph deeper than
/// [`MAX_NODE_DEPTH`] or of more than [`MAX_NODE_VISITS`] node instances:
/// the flattener names those defects itself.
pub(in crate::model) fn expanded_size(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Option<Size> {
    let mut meshes: HashMap<usize, Size> = HashMap::new();
    let mut of_mesh = |mesh: &gltf::Mesh<'_>| {
        *(meshes.entry(mesh.index())).or_insert_with(|| mesh_size(mesh, buffers))
    };
    let Some(scene) = document
        .default_scene()
        .or_else(|| document.scenes().next())
    else {
        return Some(
            document
                .meshes()
                .fold(Size::default(), |s, m| s.plus(of_mesh(&m), 1)),
        );
    };
    let mut total = Size::default();
    let mut visits = 0usize;
    let mut stack: Vec<(gltf::Node<'_>, usize)> = scene.nodes().map(|n| (n, 0)).collect();
    while let Some((node, depth)) = stack.pop() {
        visits += 1;
        if depth > MAX_NODE_DEPTH || visits > MAX_NODE_VISITS {
            return None;
        }
        if let Some(mesh) = node.mesh() {
            total = total.plus(of_mesh(&mesh), instances(&node, document, buffers));
        }
        stack.extend(node.children().map(|c| (c, depth + 1)));
    }
    Some(total)
}

/// One instance of `mesh`: its triangle primitives' positions and indices.
fn mesh_size(mesh: &gltf::Mesh<'_>, buffers: &[gltf::buffer::Data]) -> Size {
    use gltf::mesh::Mode;
    let count = |a: Option<gltf::Accessor<'_>>, what: &str| {
        a.filter(|a| check_accessor(a, what, buffers).is_ok())
            .map_or(0, |a| a.count() as u64)
    };
    (mesh.primitives()).fold(Size::default(), |size, p| {
        let vertices = count(p.get(&gltf::Semantic::Positions), "POSITION");
        let n = p.indices().map_or(vertices, |a| count(Some(a), "indices"));
        let indices = match p.mode() {
            Mode::Triangles => n / 3 * 3,
            Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2).saturating_mul(3),
            _ => return size,
        };
        size.plus(Size { vertices, indices }, 1)
    })
}

/// The copies of a node's mesh: `EXT_mesh_gpu_instancing`'s instance count
/// (its longest attribute that fits its buffer), else 1.
fn instances(
    node: &gltf::Node<'_>,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> u64 {
    let Some(attributes) = node
        .extension_value("EXT_mesh_gpu_instancing")
        .and_then(|e| e.get("attributes"))
        .and_then(|a| a.as_object())
    else {
        return 1;
    };
    (attributes.iter())
        .filter_map(|(semantic, i)| {
            let a = document
                .accessors()
                .nth(usize::try_from(i.as_u64()?).ok()?)?;
            check_accessor(&a, semantic, buffers)
                .is_ok()
                .then(|| a.count() as u64)
        })
        .max()
        .unwrap_or(1)
}
