//! Flattening a glTF scene into one vertex buffer and per-surface index
//! buckets ([`Flattener`]): node transforms, instancing, skins, materials
//! and textures baked, as the module docs of [`super`] describe.

mod check;
mod size;

use super::*;
use check::{Defect, check_accessor, check_primitive_accessors};
pub(super) use size::expanded_size;

pub(super) struct Flattener<'a> {
    pub(super) file: &'a Path,
    pub(super) document: &'a gltf::Document,
    pub(super) base_dir: Option<&'a Path>,
    pub(super) policy: UriPolicy,
    pub(super) buffers: &'a [gltf::buffer::Data],
    pub(super) vertices: Vec<Vertex>,
    /// Triangle indices per texture slot.
    /// Triangle indices per (texture, double-sided, alpha mask).
    pub(super) buckets: BTreeMap<(Option<usize>, bool, bool), Vec<u32>>,
    pub(super) textures: Vec<CpuTexture>,
    /// (image, sampler) → slot in `textures` (None: could not be decoded).
    pub(super) texture_slots: BTreeMap<(usize, Option<usize>), Option<usize>>,
    pub(super) warnings: Vec<String>,
    /// Node instances visited so far (bounded by [`MAX_NODE_VISITS`]).
    pub(super) visits: usize,
    /// Each node's parent (the first node listing it as a child), for joint world matrices.
    pub(super) parents: Vec<Option<usize>>,
}

/// `"name" (#3)` or `#3`, for messages.
fn node_label(node: &gltf::Node<'_>) -> String {
    match node.name() {
        Some(name) => format!("\"{name}\" (#{})", node.index()),
        None => format!("#{}", node.index()),
    }
}

impl Flattener<'_> {
    /// `root` and the nodes under it, in document order (each node before
    /// its children, children in the order listed), from an explicit stack:
    /// a recursion of [`MAX_NODE_DEPTH`] calls overflowed a 256 KiB main
    /// stack (`ulimit -s 256`), an abort no error can report.
    pub(super) fn node(
        &mut self,
        root: &gltf::Node<'_>,
        parent: DMat4,
        depth: usize,
    ) -> Result<(), ModelError> {
        let mut stack = vec![(root.clone(), parent, depth)];
        while let Some((node, parent, depth)) = stack.pop() {
            let world = self.one_node(&node, parent, depth)?;
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world, depth + 1)));
        }
        Ok(())
    }

    /// One node's meshes, placed by `parent` times its own transform;
    /// returns that world transform, its children's parent.
    fn one_node(
        &mut self,
        node: &gltf::Node<'_>,
        parent: DMat4,
        depth: usize,
    ) -> Result<DMat4, ModelError> {
        if depth > MAX_NODE_DEPTH {
            return Err(ModelError::Malformed {
                file: self.file.to_owned(),
                reason: format!("node hierarchy deeper than {MAX_NODE_DEPTH} (a cycle?)"),
            });
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            let nodes = self.document.nodes().len();
            if nodes > MAX_NODE_VISITS {
                // Many nodes, not a graph that expands: say so.
                return Err(ModelError::TooManyNodes {
                    file: self.file.to_owned(),
                    nodes,
                    limit: MAX_NODE_VISITS,
                });
            }
            return Err(ModelError::NodeGraph {
                file: self.file.to_owned(),
                node: node.index(),
                limit: MAX_NODE_VISITS,
            });
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) {
            let joints = self.skin_matrices(node, &skin)?;
            let label = node_label(node);
            self.skinned_mesh(&mesh, world, Some((joints.as_slice(), label.as_str())))?;
        } else if let Some(mesh) = node.mesh() {
            match self.gpu_instances(node)? {
                Some(instances) => {
                    for instance in instances {
                        self.mesh(&mesh, world * instance)?;
                    }
                }
                None => self.mesh(&mesh, world)?,
            }
        }
        Ok(world)
    }

    /// The per-instance transforms of an `EXT_mesh_gpu_instancing` node, if it has them.
    fn gpu_instances(&mut self, node: &gltf::Node<'_>) -> Result<Option<Vec<DMat4>>, ModelError> {
        let Some(attributes) = node
            .extension_value("EXT_mesh_gpu_instancing")
            .and_then(|e| e.get("attributes"))
            .and_then(|a| a.as_object())
        else {
            return Ok(None);
        };
        let (file, document, buffers) = (self.file, self.document, self.buffers);
        let err = |reason: String| ModelError::Malformed {
            file: file.to_owned(),
            reason: format!("EXT_mesh_gpu_instancing on node {}: {reason}", node.index()),
        };
        let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|d| &d.0[..]);
        let read = |semantic: &str,
                    dims: gltf::accessor::Dimensions|
         -> Result<Option<Vec<[f32; 4]>>, ModelError> {
            let Some(i) = attributes.get(semantic).and_then(serde_json::Value::as_u64) else {
                return Ok(None);
            };
            let a = document
                .accessors()
                .nth(i as usize)
                .ok_or_else(|| err(format!("{semantic} accessor {i} does not exist")))?;
            if a.data_type() != gltf::accessor::DataType::F32 || a.dimensions() != dims {
                return Err(err(format!("{semantic} must be a float {dims:?} accessor")));
            }
            let out = if dims == gltf::accessor::Dimensions::Vec4 {
                gltf::accessor::Iter::<[f32; 4]>::new(a, get).map(Iterator::collect)
            } else {
                gltf::accessor::Iter::<[f32; 3]>::new(a, get)
                    .map(|it| it.map(|[x, y, z]| [x, y, z, 0.0]).collect())
            };
            out.map(Some)
                .ok_or_else(|| err(format!("{semantic} data is missing")))
        };
        let translations = read("TRANSLATION", gltf::accessor::Dimensions::Vec3)?;
        let rotations = read("ROTATION", gltf::accessor::Dimensions::Vec4)?;
        let scales = read("SCALE", gltf::accessor::Dimensions::Vec3)?;
        let count = [&translations, &rotations, &scales]
            .iter()
            .filter_map(|v| v.as_ref().map(Vec::len))
            .max();
        let Some(count) = count else { return Ok(None) };
        let at = |v: &Option<Vec<[f32; 4]>>, i: usize| {
            v.as_ref().and_then(|v| v.get(i)).map(|x| x.map(f64::from))
        };
        let instances = (0..count)
            .map(|i| {
                let t = at(&translations, i).map_or(DVec3::ZERO, |t| DVec3::new(t[0], t[1], t[2]));
                let r =
                    at(&rotations, i).map_or(DQuat::IDENTITY, |r| DQuat::from_array(r).normalize());
                let s = at(&scales, i).map_or(DVec3::ONE, |s| DVec3::new(s[0], s[1], s[2]));
                DMat4::from_scale_rotation_translation(s, r, t)
            })
            .collect();
        Ok(Some(instances))
    }

    /// The texture slot of a glTF texture, decoding it on first use.
    fn texture_slot(&mut self, texture: &gltf::Texture<'_>) -> Option<usize> {
        let image = texture.source();
        let key = (image.index(), texture.sampler().index());
        if let Some(slot) = self.texture_slots.get(&key) {
            return *slot;
        }
        let label = image
            .name()
            .or(texture.name())
            .map_or_else(|| format!("image #{}", image.index()), str::to_string);
        let slot = match image_data(image.source(), self.base_dir, self.buffers, self.policy) {
            Ok(data) => {
                match to_rgba8(&data) {
                    Some(rgba) => {
                        let sampler = texture.sampler();
                        let wrap = |w: gltf::texture::WrappingMode| match w {
                            gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
                            gltf::texture::WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
                            gltf::texture::WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
                        };
                        let (width, height, rgba8) = limit_size(data.width, data.height, rgba);
                        self.textures.push(CpuTexture {
                            name: label,
                            width,
                            height,
                            rgba8,
                            wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
                        });
                        Some(self.textures.len() - 1)
                    }
                    None => {
                        self.warnings.push(format!("texture {label}: unsupported pixel format {:?}; base colour factor used", data.format));
                        None
                    }
                }
            }
            Err(e) => {
                self.warnings.push(format!(
                    "texture {label} cannot be decoded ({e}); base colour factor used"
                ));
                None
            }
        };
        self.texture_slots.insert(key, slot);
        slot
    }

    pub(super) fn mesh(&mut self, mesh: &gltf::Mesh<'_>, world: DMat4) -> Result<(), ModelError> {
        self.skinned_mesh(mesh, world, None)
    }

    /// The joint matrices `world(joint) · inverseBind(joint)` of a node's
    /// skin: the pose the file's node transforms put the skeleton in.
    fn skin_matrices(
        &mut self,
        node: &gltf::Node<'_>,
        skin: &gltf::Skin<'_>,
    ) -> Result<Vec<DMat4>, ModelError> {
        let (file, buffers) = (self.file, self.buffers);
        let err = |reason: String| ModelError::Malformed {
            file: file.to_owned(),
            reason: format!("node {} skin {}: {reason}", node_label(node), skin.index()),
        };
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let inverse_bind: Vec<DMat4> = match skin.inverse_bind_matrices() {
            Some(accessor) => {
                check_accessor(&accessor, "inverseBindMatrices", buffers)
                    .map_err(|d| err(d.to_string()))?;
                skin.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]))
                    .read_inverse_bind_matrices()
                    .ok_or_else(|| err("inverse bind matrices cannot be read".into()))?
                    .map(|m| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from))))
                    .collect()
            }
            None => vec![DMat4::IDENTITY; joints.len()],
        };
        if inverse_bind.len() < joints.len() {
            return Err(err(format!(
                "{} inverse bind matrices for {} joints",
                inverse_bind.len(),
                joints.len()
            )));
        }
        joints
            .iter()
            .zip(&inverse_bind)
            .map(|(&joint, ibm)| {
                let world = self.node_world(joint).map_err(|d| err(d.to_string()))?;
                Ok(world * *ibm)
            })
            .collect()
    }

    /// A node's world matrix: the product of its ancestors' transforms (the
    /// first parent that lists it, for a file that breaks the tree rule).
    fn node_world(&self, index: usize) -> Result<DMat4, Defect> {
        let mut m = DMat4::IDENTITY;
        let mut at = Some(index);
        let mut depth = 0;
        while let Some(i) = at {
            depth += 1;
            if depth > MAX_NODE_DEPTH {
                return Err(Defect::DeepJoint { index });
            }
            let node = self.document.nodes().nth(i).ok_or(Defect::NoJointNode(i))?;
            let local =
                DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
            m = local * m;
            at = self.parents.get(i).copied().flatten();
        }
        Ok(m)
    }

    /// Bake one mesh instance: with `skin` (joint matrices), each vertex is
    /// moved by its weighted joints, as glTF skinning asks (the node's own
    /// transform is then not used); without, by `world`.
    fn skinned_mesh(
        &mut self,
        mesh: &gltf::Mesh<'_>,
        world: DMat4,
        skin: Option<(&[DMat4], &str)>,
    ) -> Result<(), ModelError> {
        let mesh_name = mesh
            .name()
            .map_or_else(|| format!("#{}", mesh.index()), str::to_string);
        let mut instance = Instance {
            mesh_name: &mesh_name,
            world,
            normal_matrix: DMat3::from_mat4(world).inverse().transpose(),
            flips: DMat3::from_mat4(world).determinant() < 0.0,
            skin,
        };
        for (p, primitive) in mesh.primitives().enumerate() {
            self.primitive(&primitive, p, &mut instance)?;
        }
        Ok(())
    }

    /// Bake primitive `p` of a mesh instance.
    fn primitive(
        &mut self,
        primitive: &gltf::Primitive<'_>,
        p: usize,
        instance: &mut Instance<'_>,
    ) -> Result<(), ModelError> {
        let mesh_name = instance.mesh_name;
        let err = |reason: String| ModelError::Primitive {
            file: self.file.to_owned(),
            mesh: mesh_name.to_owned(),
            primitive: p,
            reason,
        };
        use gltf::mesh::Mode;
        let mode = primitive.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warnings.push(format!(
                "mesh \"{mesh_name}\" primitive {p}: {mode:?} skipped (only triangles are drawn)"
            ));
            return Ok(());
        }
        let buffers = self.buffers;
        check_primitive_accessors(primitive, buffers).map_err(|d| err(d.to_string()))?;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<[f32; 3]> = reader
            .read_positions()
            .ok_or_else(|| err("no POSITION attribute".into()))?
            .collect();
        if positions.is_empty() {
            return Ok(());
        }
        if self.vertices.len() + positions.len() > MAX_VERTICES {
            return Err(err(format!(
                "more than {MAX_VERTICES} vertices after expanding instances"
            )));
        }
        let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(Iterator::collect);
        let colors: Option<Vec<[f32; 4]>> =
            reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
        let material = primitive.material();
        let (factor, cutoff, material_params) = material_of(&material);
        let (texture, uvs) = self.base_color_uvs(&material, &reader, mesh_name, p);
        let raw_indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(bad) = raw_indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(err(format!(
                "index {bad} is out of range for {} vertices",
                positions.len()
            )));
        }
        let n = positions.len();
        if normals.as_ref().is_some_and(|v| v.len() != n)
            || colors.as_ref().is_some_and(|v| v.len() != n)
            || uvs.as_ref().is_some_and(|v| v.len() != n)
        {
            return Err(err("attribute counts differ from the POSITION count".into()));
        }
        // Per-vertex skinning matrices: Σ weight · joint matrix.
        let skinning = (self.skinning(&reader, instance, n, p)).map_err(|d| err(d.to_string()))?;
        let baked = Baked {
            positions,
            normals,
            colors,
            uvs,
            skinning,
            factor,
            material: material_params,
        };
        let base = self.push_vertices(&baked, instance);
        let bucket = self
            .buckets
            .entry((texture, material.double_sided(), cutoff > 0.0))
            .or_default();
        let start = bucket.len();
        for [a, b, c] in triangulate(mode, &raw_indices) {
            let tri = if instance.flips { [a, c, b] } else { [a, b, c] };
            bucket.extend(tri.map(|i| base + i));
        }
        if baked.normals.is_none() {
            compute_normals(&mut self.vertices[base as usize..], &bucket[start..], base);
        }
        Ok(())
    }

    /// The base colour texture's slot and the primitive's UVs for it (its UV
    /// set, possibly overridden by the transform, with the transform baked).
    fn base_color_uvs<'a, 's, F>(
        &mut self,
        material: &gltf::Material<'_>,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        mesh_name: &str,
        p: usize,
    ) -> (Option<usize>, Option<Vec<[f32; 2]>>)
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let Some(info) = material.pbr_metallic_roughness().base_color_texture() else {
            return (None, None);
        };
        let transform = info.texture_transform();
        let set = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        match reader.read_tex_coords(set) {
            Some(tc) => {
                let mut coords: Vec<[f32; 2]> = tc.into_f32().collect();
                if let Some(t) = &transform {
                    let m = uv_transform(t.offset(), t.rotation(), t.scale());
                    for uv in &mut coords {
                        *uv = m(*uv);
                    }
                }
                (self.texture_slot(&info.texture()), Some(coords))
            }
            None => {
                self.warnings.push(format!("mesh \"{mesh_name}\" primitive {p}: base colour texture uses TEXCOORD_{set}, which is missing; texture skipped"));
                (None, None)
            }
        }
    }

    /// Per-vertex skinning matrices of a primitive of `n` vertices when the
    /// instance has a skin and the primitive joints and weights (a skin
    /// without them: a warning, the node's transform). A skinned primitive
    /// sets the instance's winding from its first vertex's matrix.
    fn skinning<'a, 's, F>(
        &mut self,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        instance: &mut Instance<'_>,
        n: usize,
        p: usize,
    ) -> Result<Option<Vec<DMat4>>, Defect>
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let Some((joint_matrices, node)) = instance.skin else {
            return Ok(None);
        };
        let (Some(joints), Some(weights)) = (reader.read_joints(0), reader.read_weights(0)) else {
            let mesh_name = instance.mesh_name;
            self.warnings.push(format!("node {node}: mesh \"{mesh_name}\" primitive {p} has a skin but no JOINTS_0/WEIGHTS_0; drawn with the node's transform"));
            return Ok(None);
        };
        let joints: Vec<[u16; 4]> = joints.into_u16().collect();
        let weights: Vec<[f32; 4]> = weights.into_f32().collect();
        if joints.len() != n || weights.len() != n {
            return Err(Defect::SkinCounts);
        }
        let out =
            skin_per_vertex(&joints, &weights, joint_matrices, instance.world).map_err(|d| {
                Defect::InNode {
                    node: node.to_owned(),
                    defect: Box::new(d),
                }
            })?;
        if let Some(first) = out.first() {
            instance.flips = DMat3::from_mat4(*first).determinant() < 0.0;
        }
        Ok(Some(out))
    }

    /// Append a primitive's vertices, moved by their skinning matrices or
    /// the instance's transform; returns the index of the first.
    fn push_vertices(&mut self, baked: &Baked, instance: &Instance<'_>) -> u32 {
        let base = self.vertices.len() as u32;
        let factor = baked.factor;
        for (i, pos) in baked.positions.iter().enumerate() {
            let (m, nm) = match &baked.skinning {
                Some(s) => (s[i], DMat3::from_mat4(s[i]).inverse().transpose()),
                None => (instance.world, instance.normal_matrix),
            };
            let p = m.transform_point3(DVec3::from(pos.map(f64::from)));
            let n = baked
                .normals
                .as_ref()
                .map(|n| (nm * DVec3::from(n[i].map(f64::from))).normalize_or_zero())
                .unwrap_or(DVec3::ZERO);
            let c = baked.colors.as_ref().map_or([1.0; 4], |c| c[i]);
            self.vertices.push(Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                color: [
                    c[0] * factor[0],
                    c[1] * factor[1],
                    c[2] * factor[2],
                    c[3] * factor[3],
                ],
                uv: baked.uvs.as_ref().map_or([0.0; 2], |u| u[i]),
                material: baked.material,
            });
        }
        base
    }
}

/// One mesh instance being baked: its name, transform and skin.
struct Instance<'a> {
    mesh_name: &'a str,
    world: DMat4,
    normal_matrix: DMat3,
    /// Whether triangles are wound the other way (a mirroring transform);
    /// a skinned primitive sets it from its first vertex's matrix, for
    /// itself and the primitives after it.
    flips: bool,
    skin: Option<(&'a [DMat4], &'a str)>,
}

/// A primitive's vertex attributes as read, and its material per vertex.
struct Baked {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[f32; 4]>>,
    uvs: Option<Vec<[f32; 2]>>,
    skinning: Option<Vec<DMat4>>,
    factor: [f32; 4],
    material: [f32; 4],
}

/// A material's base colour factor, alpha cutoff (0: opaque) and the
/// per-vertex parameters (metallic, roughness, unlit, cutoff).
fn material_of(material: &gltf::Material<'_>) -> ([f32; 4], f32, [f32; 4]) {
    let pbr = material.pbr_metallic_roughness();
    let cutoff = match material.alpha_mode() {
        gltf::material::AlphaMode::Mask => material.alpha_cutoff().unwrap_or(0.5).max(1e-6),
        gltf::material::AlphaMode::Blend => super::BLEND_MARK,
        gltf::material::AlphaMode::Opaque => 0.0,
    };
    let params = [
        pbr.metallic_factor(),
        pbr.roughness_factor(),
        if material.unlit() { 1.0 } else { 0.0 },
        cutoff,
    ];
    (pbr.base_color_factor(), cutoff, params)
}

/// Per-vertex skinning matrices: Σ weight · joint matrix over the vertex's
/// non-zero weights, normalised by their sum (`world` when all are zero).
fn skin_per_vertex(
    joints: &[[u16; 4]],
    weights: &[[f32; 4]],
    joint_matrices: &[DMat4],
    world: DMat4,
) -> Result<Vec<DMat4>, Defect> {
    let mut out = Vec::with_capacity(joints.len());
    for (j, w) in joints.iter().zip(weights) {
        let mut m = DMat4::ZERO;
        let mut total = 0.0;
        for (&joint, &weight) in j.iter().zip(w) {
            if weight == 0.0 {
                continue;
            }
            let jm = (joint_matrices.get(usize::from(joint))).ok_or(Defect::JointRange {
                joint,
                joints: joint_matrices.len(),
            })?;
            m += *jm * f64::from(weight);
            total += f64::from(weight);
        }
        out.push(if total > 0.0 {
            m * (1.0 / total)
        } else {
            world
        });
    }
    Ok(out)
}

/// Any decoded glTF image as RGBA8 (16-bit channels keep their high byte).
fn to_rgba8(data: &gltf::image::Data) -> Option<Vec<u8>> {
    use gltf::image::Format;
    let px = &data.pixels;
    let f32_to_u8 = |c: &[u8]| {
        (f32::from_le_bytes([c[0], c[1], c[2], c[3]]).clamp(0.0, 1.0) * 255.0).round() as u8
    };
    let out: Vec<u8> = match data.format {
        Format::R8 => px.iter().flat_map(|&r| [r, r, r, 255]).collect(),
        Format::R8G8 => px
            .chunks_exact(2)
            .flat_map(|c| [c[0], c[0], c[0], c[1]])
            .collect(),
        Format::R8G8B8 => px
            .chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        Format::R8G8B8A8 => px.clone(),
        Format::R16 => px
            .chunks_exact(2)
            .flat_map(|c| [c[1], c[1], c[1], 255])
            .collect(),
        Format::R16G16 => px
            .chunks_exact(4)
            .flat_map(|c| [c[1], c[1], c[1], c[3]])
            .collect(),
        Format::R16G16B16 => px
            .chunks_exact(6)
            .flat_map(|c| [c[1], c[3], c[5], 255])
            .collect(),
        Format::R16G16B16A16 => px
            .chunks_exact(8)
            .flat_map(|c| [c[1], c[3], c[5], c[7]])
            .collect(),
        Format::R32G32B32FLOAT => px
            .chunks_exact(12)
            .flat_map(|c| {
                [
                    f32_to_u8(&c[0..4]),
                    f32_to_u8(&c[4..8]),
                    f32_to_u8(&c[8..12]),
                    255,
                ]
            })
            .collect(),
        Format::R32G32B32A32FLOAT => px
            .chunks_exact(16)
            .flat_map(|c| {
                [
                    f32_to_u8(&c[0..4]),
                    f32_to_u8(&c[4..8]),
                    f32_to_u8(&c[8..12]),
                    f32_to_u8(&c[12..16]),
                ]
            })
            .collect(),
    };
    (out.len() == data.width as usize * data.height as usize * 4 && !out.is_empty()).then_some(out)
}

/// Downscale to at most [`MAX_TEXTURE_SIDE`] a side.
fn limit_size(width: u32, height: u32, rgba: Vec<u8>) -> (u32, u32, Vec<u8>) {
    let side = width.max(height);
    if side <= MAX_TEXTURE_SIDE {
        return (width, height, rgba);
    }
    let scale = f64::from(MAX_TEXTURE_SIDE) / f64::from(side);
    let (w, h) = (
        ((f64::from(width) * scale).round() as u32).max(1),
        ((f64::from(height) * scale).round() as u32).max(1),
    );
    match image::RgbaImage::from_raw(width, height, rgba) {
        Some(img) => (
            w,
            h,
            image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle).into_raw(),
        ),
        None => (1, 1, vec![255; 4]),
    }
}

/// Area-weighted smooth normals for a primitive that has none.
fn compute_normals(vertices: &mut [Vertex], indices: &[u32], base: u32) {
    let mut acc = vec![Vec3::ZERO; vertices.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| (i - base) as usize);
        let [pa, pb, pc] = [a, b, c].map(|i| Vec3::from(vertices[i].position));
        let n = (pb - pa).cross(pc - pa);
        for i in [a, b, c] {
            acc[i] += n;
        }
    }
    for (v, n) in vertices.iter_mut().zip(acc) {
        v.normal = n.normalize_or_zero().to_array();
    }
}
