//! The checks of a glTF file's data before it is read: accessors in bounds
//! of their buffer views and buffers (the glTF reader answers an overrun with
//! "no data", which would read as a missing attribute), sparse entries in
//! range, positions and normals float VEC3; and [`Defect`], what they (or the
//! skinning) found wrong: the reason in the `ModelError` that names the file.

use crate::model::MAX_NODE_DEPTH;

/// What a check of a glTF file's data found wrong: the reason in the
/// `ModelError` that names the file and the mesh, node or skin.
#[derive(Debug, thiserror::Error)]
pub(super) enum Defect {
    #[error("joint node {index} has more than {MAX_NODE_DEPTH} ancestors (a cycle?)")]
    DeepJoint { index: usize },
    #[error("joint node {0} does not exist")]
    NoJointNode(usize),
    #[error("accessor {index} ({semantic}) must be float VEC3, not {data_type:?} {dimensions:?}")]
    NotFloatVec3 {
        index: usize,
        semantic: String,
        data_type: gltf::accessor::DataType,
        dimensions: gltf::accessor::Dimensions,
    },
    #[error("JOINTS_0/WEIGHTS_0 counts differ from the POSITION count")]
    SkinCounts,
    #[error("joint {joint} is out of range for its skin's {joints} joints")]
    JointRange { joint: u16, joints: usize },
    /// A defect of the skin of a node (its label).
    #[error("node {node}: {defect}")]
    InNode { node: String, defect: Box<Defect> },
    #[error("accessor {index} ({semantic}) is out of bounds: {overrun}")]
    OutOfBounds {
        index: usize,
        semantic: String,
        overrun: Overrun,
    },
    #[error("accessor {index} ({semantic}) has {n} sparse entries for {count} elements")]
    SparseCount {
        index: usize,
        semantic: String,
        n: usize,
        count: usize,
    },
    #[error(
        "accessor {index} ({semantic}): sparse index {value} (entry {entry}) is out of range for {count} elements"
    )]
    SparseIndex {
        index: usize,
        semantic: String,
        value: u64,
        entry: usize,
        count: usize,
    },
}

/// Where an accessor reads past its data (`end`: None when the sum overflows).
#[derive(Debug, thiserror::Error)]
pub(super) enum Overrun {
    #[error(
        "its buffer view {view} spans bytes {offset}..{} of buffer {buffer}, which holds {data} bytes",
        or_text(*end, "overflow")
    )]
    Buffer {
        view: usize,
        offset: usize,
        end: Option<usize>,
        buffer: usize,
        data: usize,
    },
    #[error(
        "{count} elements of {size} bytes (stride {stride}) from byte {offset} need {} bytes of buffer view {view}, which has {length}",
        or_text(*end, "more than 2⁶⁴")
    )]
    Elements {
        count: usize,
        size: usize,
        stride: usize,
        offset: usize,
        end: Option<usize>,
        view: usize,
        length: usize,
    },
    #[error(
        "{what}: {n} × {size} bytes from byte {offset} overrun buffer view {view} ({length} bytes)"
    )]
    Sparse {
        what: &'static str,
        n: usize,
        size: usize,
        offset: usize,
        view: usize,
        length: usize,
    },
}

/// `n`, or `none` for a sum that overflowed.
fn or_text(n: Option<usize>, none: &str) -> String {
    n.map_or_else(|| none.to_owned(), |n| n.to_string())
}

/// Every attribute accessor of a primitive in bounds, positions and
/// normals float VEC3, and its index accessor in bounds.
pub(super) fn check_primitive_accessors(
    primitive: &gltf::Primitive<'_>,
    buffers: &[gltf::buffer::Data],
) -> Result<(), Defect> {
    for (semantic, accessor) in primitive.attributes() {
        check_accessor(&accessor, &semantic.to_string(), buffers)?;
        // Positions and normals are read as float triples only.
        use gltf::accessor::{DataType, Dimensions};
        if matches!(
            semantic,
            gltf::Semantic::Positions | gltf::Semantic::Normals
        ) && (accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3)
        {
            return Err(Defect::NotFloatVec3 {
                index: accessor.index(),
                semantic: semantic.to_string(),
                data_type: accessor.data_type(),
                dimensions: accessor.dimensions(),
            });
        }
    }
    if let Some(accessor) = primitive.indices() {
        check_accessor(&accessor, "indices", buffers)?;
    }
    Ok(())
}

/// A named error if `accessor` (used as `semantic`) reads past the end of
/// its buffer view, or its view past the end of its buffer's data, or its
/// sparse entries are more than its elements or name one it lacks. The glTF
/// reader answers such an accessor with "no data", which would otherwise
/// read as a missing attribute.
pub(super) fn check_accessor(
    accessor: &gltf::Accessor<'_>,
    semantic: &str,
    buffers: &[gltf::buffer::Data],
) -> Result<(), Defect> {
    let index = accessor.index();
    let out = |overrun: Overrun| Defect::OutOfBounds {
        index,
        semantic: semantic.to_owned(),
        overrun,
    };
    elements_fit(accessor, buffers).map_err(out)?;
    let Some(sparse) = accessor.sparse() else {
        return Ok(());
    };
    sparse_fits(accessor, &sparse, buffers).map_err(out)?;
    let (n, count) = (sparse.count(), accessor.count());
    if n > count {
        return Err(Defect::SparseCount {
            index,
            semantic: semantic.to_owned(),
            n,
            count,
        });
    }
    if let Some((entry, value)) = sparse_index_past(&sparse, count, buffers) {
        return Err(Defect::SparseIndex {
            index,
            semantic: semantic.to_owned(),
            value,
            entry,
            count,
        });
    }
    Ok(())
}

/// The length of `view`, or where it runs past its buffer's data.
fn view_fits(
    view: &gltf::buffer::View<'_>,
    buffers: &[gltf::buffer::Data],
) -> Result<usize, Overrun> {
    let data = buffers.get(view.buffer().index()).map_or(0, |d| d.0.len());
    let end = view.offset().checked_add(view.length());
    if end.is_none_or(|end| end > data) {
        return Err(Overrun::Buffer {
            view: view.index(),
            offset: view.offset(),
            end,
            buffer: view.buffer().index(),
            data,
        });
    }
    Ok(view.length())
}

/// Whether the accessor's view fits its buffer and its elements fit the view
/// (an accessor without a view reads nothing from a buffer).
fn elements_fit(
    accessor: &gltf::Accessor<'_>,
    buffers: &[gltf::buffer::Data],
) -> Result<(), Overrun> {
    let Some(view) = accessor.view() else {
        return Ok(());
    };
    let length = view_fits(&view, buffers)?;
    let count = accessor.count();
    let size = accessor.size();
    let stride = view.stride().unwrap_or(size);
    let end = count
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(accessor.offset()));
    if count > 0 && end.is_none_or(|end| end > length) {
        return Err(Overrun::Elements {
            count,
            size,
            stride,
            offset: accessor.offset(),
            end,
            view: view.index(),
            length,
        });
    }
    Ok(())
}

/// Whether the sparse indices and values each fit their buffer view (and
/// it its buffer).
fn sparse_fits(
    accessor: &gltf::Accessor<'_>,
    sparse: &gltf::accessor::sparse::Sparse<'_>,
    buffers: &[gltf::buffer::Data],
) -> Result<(), Overrun> {
    let n = sparse.count();
    let indices = sparse.indices();
    let values = sparse.values();
    let parts = [
        (
            "sparse indices",
            indices.view(),
            indices.offset(),
            indices.index_type().size(),
        ),
        (
            "sparse values",
            values.view(),
            values.offset(),
            accessor.size(),
        ),
    ];
    for (what, view, offset, size) in parts {
        let length = view_fits(&view, buffers)?;
        let end = n.checked_mul(size).and_then(|b| b.checked_add(offset));
        if end.is_none_or(|end| end > length) {
            return Err(Overrun::Sparse {
                what,
                n,
                size,
                offset,
                view: view.index(),
                length,
            });
        }
    }
    Ok(())
}

/// The first sparse index (entry, value) not below `count`: each names an
/// element to replace. Read little-endian from the (checked) indices view.
fn sparse_index_past(
    sparse: &gltf::accessor::sparse::Sparse<'_>,
    count: usize,
    buffers: &[gltf::buffer::Data],
) -> Option<(usize, u64)> {
    let indices = sparse.indices();
    let view = indices.view();
    let data = buffers
        .get(view.buffer().index())
        .map_or(&[][..], |d| &d.0[..]);
    let size = indices.index_type().size();
    let start = view.offset() + indices.offset();
    for k in 0..sparse.count() {
        let at = start + k * size;
        let bytes = data.get(at..at + size)?;
        let value = bytes
            .iter()
            .rev()
            .fold(0u64, |v, &b| (v << 8) | u64::from(b));
        if value >= count as u64 {
            return Some((k, value));
        }
    }
    None
}
