//! A minimal SPIR-V reflector: the descriptor bindings, push-constant size and uniform/push block
//! layouts of one module. Shared by `build.rs` (which embeds the results in `shaders.rs`) and
//! the engine's tests; depends on nothing but `std`.
//!
//! Only what the engine's pass checks need is decoded: `OpDecorate`/`OpMemberDecorate`
//! (Block, BufferBlock, Binding, DescriptorSet, Offset, ArrayStride, MatrixStride), names, the
//! type declarations and the module-scope variables.

use std::collections::HashMap;

/// What kind of descriptor a shader variable needs (Vulkan's `VkDescriptorType` subset used here).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DescriptorKind {
    /// `uniform` block.
    UniformBuffer,
    /// `buffer` block.
    StorageBuffer,
    /// `image*` (storage image).
    StorageImage,
    /// `sampler*` (combined image sampler).
    CombinedImageSampler,
    /// `texture*` (sampled image without sampler).
    SampledImage,
    /// `sampler` alone.
    Sampler,
    /// `imageBuffer` (storage texel buffer).
    StorageTexelBuffer,
}

/// One descriptor binding as the shader declares it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingInfo {
    /// `layout(set = …)`.
    pub set: u32,
    /// `layout(binding = …)`.
    pub binding: u32,
    /// Descriptor type.
    pub kind: DescriptorKind,
    /// Array length (1 for a single descriptor).
    pub count: u32,
    /// Variable or block instance name, when the module carries debug names.
    pub name: String,
}

/// Layout of a uniform or push-constant block: its members' byte offsets and its size.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockInfo {
    /// Block type name (e.g. `Params`).
    pub name: String,
    /// Binding of a uniform block; `None` for the push-constant block.
    pub binding: Option<u32>,
    /// Size in bytes (offset + size of the last member).
    pub size: u32,
    /// `(member name, byte offset)` in declaration order.
    pub members: Vec<(String, u32)>,
}

/// Everything reflected from one module.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ModuleInfo {
    /// Descriptor bindings, sorted by (set, binding).
    pub bindings: Vec<BindingInfo>,
    /// Push-constant block size in bytes (0 when there is none).
    pub push_size: u32,
    /// Uniform and push-constant block layouts.
    pub blocks: Vec<BlockInfo>,
    /// A compute module's workgroup size (`OpExecutionMode LocalSize`).
    pub local_size: Option<[u32; 3]>,
}

#[derive(Clone, Debug)]
enum Ty {
    Scalar(u32),
    Vector(u32, u32),
    Matrix(u32, u32),
    Array(u32, u32),
    RuntimeArray(u32),
    Struct(Vec<u32>),
    Image { sampled: u32, dim: u32 },
    Sampler,
    SampledImage,
    Pointer(u32),
    Other,
}

const OP_NAME: u32 = 5;
const OP_EXECUTION_MODE: u32 = 16;
const EM_LOCAL_SIZE: u32 = 17;
const OP_MEMBER_NAME: u32 = 6;
const OP_TYPE_BOOL: u32 = 20;
const OP_TYPE_INT: u32 = 21;
const OP_TYPE_FLOAT: u32 = 22;
const OP_TYPE_VECTOR: u32 = 23;
const OP_TYPE_MATRIX: u32 = 24;
const OP_TYPE_IMAGE: u32 = 25;
/// `Dim Buffer` of `OpTypeImage`.
const DIM_BUFFER: u32 = 5;
const OP_TYPE_SAMPLER: u32 = 26;
const OP_TYPE_SAMPLED_IMAGE: u32 = 27;
const OP_TYPE_ARRAY: u32 = 28;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_TYPE_STRUCT: u32 = 30;
const OP_TYPE_POINTER: u32 = 32;
const OP_CONSTANT: u32 = 43;
const OP_VARIABLE: u32 = 59;
const OP_DECORATE: u32 = 71;
const OP_MEMBER_DECORATE: u32 = 72;

const DEC_BLOCK: u32 = 2;
const DEC_BUFFER_BLOCK: u32 = 3;
const DEC_ARRAY_STRIDE: u32 = 6;
const DEC_MATRIX_STRIDE: u32 = 7;
const DEC_BINDING: u32 = 33;
const DEC_SET: u32 = 34;
const DEC_OFFSET: u32 = 35;

const SC_UNIFORM_CONSTANT: u32 = 0;
const SC_UNIFORM: u32 = 2;
const SC_PUSH_CONSTANT: u32 = 9;
const SC_STORAGE_BUFFER: u32 = 12;

fn string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

#[derive(Default)]
struct Module {
    names: HashMap<u32, String>,
    member_names: HashMap<(u32, u32), String>,
    decorations: HashMap<(u32, u32), u32>,
    flags: HashMap<u32, Vec<u32>>,
    member_decorations: HashMap<(u32, u32, u32), u32>,
    types: HashMap<u32, Ty>,
    constants: HashMap<u32, u32>,
    variables: Vec<(u32, u32, u32)>,
}

impl Module {
    fn size(&self, ty: u32, matrix_stride: Option<u32>) -> u32 {
        match self.types.get(&ty) {
            Some(Ty::Scalar(bytes)) => *bytes,
            Some(Ty::Vector(c, n)) => self.size(*c, None) * n,
            Some(Ty::Matrix(col, n)) => matrix_stride.unwrap_or_else(|| self.size(*col, None)) * n,
            Some(Ty::Array(e, len)) => {
                let stride = self.decorations.get(&(ty, DEC_ARRAY_STRIDE)).copied();
                stride.unwrap_or_else(|| self.size(*e, matrix_stride)) * self.constants.get(len).copied().unwrap_or(0)
            }
            Some(Ty::Struct(members)) => self.struct_layout(ty, members).0,
            _ => 0,
        }
    }

    /// A block's (size, [(member name, offset)]). A block that holds only a one-element array of
    /// a struct (the volume shaders read their blocks so, at an opaque index: `volume/common.glsl`)
    /// is laid out as that struct.
    fn block_layout(&self, ty: u32, members: &[u32]) -> (u32, Vec<(String, u32)>) {
        if let [only] = members {
            if let Some(Ty::Array(e, len)) = self.types.get(only) {
                if let (Some(1), Some(Ty::Struct(inner))) = (self.constants.get(len), self.types.get(e)) {
                    let base = self.member_decorations.get(&(ty, 0, DEC_OFFSET)).copied().unwrap_or(0);
                    let (size, out) = self.struct_layout(*e, inner);
                    return (base + size, out.into_iter().map(|(n, o)| (n, base + o)).collect());
                }
            }
        }
        self.struct_layout(ty, members)
    }

    /// (size, [(member name, offset)]).
    fn struct_layout(&self, ty: u32, members: &[u32]) -> (u32, Vec<(String, u32)>) {
        let mut size = 0;
        let mut out = Vec::new();
        for (i, &m) in members.iter().enumerate() {
            let i = i as u32;
            let offset = self.member_decorations.get(&(ty, i, DEC_OFFSET)).copied().unwrap_or(0);
            let stride = self.member_decorations.get(&(ty, i, DEC_MATRIX_STRIDE)).copied();
            size = size.max(offset + self.size(m, stride));
            out.push((self.member_names.get(&(ty, i)).cloned().unwrap_or_else(|| format!("_{i}")), offset));
        }
        (size, out)
    }
}

/// Reflects one module; `Err` names what is malformed.
pub fn reflect(words: &[u32]) -> Result<ModuleInfo, String> {
    if words.len() < 5 || words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module (bad magic)".into());
    }
    let mut m = Module::default();
    let mut local_size = None;
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let op = words[i] & 0xffff;
        if count == 0 || i + count > words.len() {
            return Err(format!("truncated instruction at word {i}"));
        }
        let a = &words[i + 1..i + count];
        let at = |k: usize| a.get(k).copied().unwrap_or(0);
        match op {
            OP_EXECUTION_MODE if at(1) == EM_LOCAL_SIZE => local_size = Some([at(2), at(3), at(4)]),
            OP_NAME => {
                m.names.insert(at(0), string(&a[1.min(a.len())..]));
            }
            OP_MEMBER_NAME => {
                m.member_names.insert((at(0), at(1)), string(&a[2.min(a.len())..]));
            }
            OP_DECORATE => match at(1) {
                DEC_BLOCK | DEC_BUFFER_BLOCK => m.flags.entry(at(0)).or_default().push(at(1)),
                d => {
                    m.decorations.insert((at(0), d), at(2));
                }
            },
            OP_MEMBER_DECORATE => {
                m.member_decorations.insert((at(0), at(1), at(2)), at(3));
            }
            OP_TYPE_BOOL => {
                m.types.insert(at(0), Ty::Scalar(4));
            }
            OP_TYPE_INT | OP_TYPE_FLOAT => {
                m.types.insert(at(0), Ty::Scalar(at(1) / 8));
            }
            OP_TYPE_VECTOR => {
                m.types.insert(at(0), Ty::Vector(at(1), at(2)));
            }
            OP_TYPE_MATRIX => {
                m.types.insert(at(0), Ty::Matrix(at(1), at(2)));
            }
            OP_TYPE_IMAGE => {
                m.types.insert(at(0), Ty::Image { sampled: at(6), dim: at(2) });
            }
            OP_TYPE_SAMPLER => {
                m.types.insert(at(0), Ty::Sampler);
            }
            OP_TYPE_SAMPLED_IMAGE => {
                m.types.insert(at(0), Ty::SampledImage);
            }
            OP_TYPE_ARRAY => {
                m.types.insert(at(0), Ty::Array(at(1), at(2)));
            }
            OP_TYPE_RUNTIME_ARRAY => {
                m.types.insert(at(0), Ty::RuntimeArray(at(1)));
            }
            OP_TYPE_STRUCT => {
                m.types.insert(at(0), Ty::Struct(a[1.min(a.len())..].to_vec()));
            }
            OP_TYPE_POINTER => {
                m.types.insert(at(0), Ty::Pointer(at(2)));
            }
            OP_CONSTANT => {
                m.constants.insert(at(1), at(2));
            }
            OP_VARIABLE => m.variables.push((at(0), at(1), at(2))),
            _ => {
                if !m.types.contains_key(&at(0)) && (19..=39).contains(&op) {
                    m.types.insert(at(0), Ty::Other);
                }
            }
        }
        i += count;
    }
    let mut info = ModuleInfo { local_size, ..Default::default() };
    for &(ptr, var, class) in &m.variables {
        let Some(Ty::Pointer(mut ty)) = m.types.get(&ptr).cloned() else { continue };
        let mut count = 1;
        if let Some(Ty::Array(e, len)) = m.types.get(&ty) {
            count = m.constants.get(len).copied().unwrap_or(1);
            ty = *e;
        } else if let Some(Ty::RuntimeArray(e)) = m.types.get(&ty) {
            count = 0;
            ty = *e;
        }
        let flags = m.flags.get(&ty).cloned().unwrap_or_default();
        let kind = match (class, m.types.get(&ty)) {
            (SC_UNIFORM, _) if flags.contains(&DEC_BUFFER_BLOCK) => DescriptorKind::StorageBuffer,
            (SC_UNIFORM, _) => DescriptorKind::UniformBuffer,
            (SC_STORAGE_BUFFER, _) => DescriptorKind::StorageBuffer,
            (SC_UNIFORM_CONSTANT, Some(Ty::SampledImage)) => DescriptorKind::CombinedImageSampler,
            (SC_UNIFORM_CONSTANT, Some(Ty::Image { sampled: 2, dim: DIM_BUFFER })) => {
                DescriptorKind::StorageTexelBuffer
            }
            (SC_UNIFORM_CONSTANT, Some(Ty::Image { sampled: 2, .. })) => DescriptorKind::StorageImage,
            (SC_UNIFORM_CONSTANT, Some(Ty::Image { .. })) => DescriptorKind::SampledImage,
            (SC_UNIFORM_CONSTANT, Some(Ty::Sampler)) => DescriptorKind::Sampler,
            (SC_PUSH_CONSTANT, Some(Ty::Struct(members))) => {
                let (size, members) = m.block_layout(ty, members);
                info.push_size = size;
                info.blocks.push(BlockInfo {
                    name: m.names.get(&ty).cloned().unwrap_or_default(),
                    binding: None,
                    size,
                    members,
                });
                continue;
            }
            _ => continue,
        };
        let binding = m.decorations.get(&(var, DEC_BINDING)).copied().unwrap_or(0);
        if kind == DescriptorKind::UniformBuffer {
            if let Some(Ty::Struct(members)) = m.types.get(&ty) {
                let (size, members) = m.block_layout(ty, members);
                let name = m.names.get(&ty).cloned().unwrap_or_default();
                info.blocks.push(BlockInfo { name, binding: Some(binding), size, members });
            }
        }
        let name = m.names.get(&var).cloned().filter(|n| !n.is_empty()).or_else(|| m.names.get(&ty).cloned());
        info.bindings.push(BindingInfo {
            set: m.decorations.get(&(var, DEC_SET)).copied().unwrap_or(0),
            binding,
            kind,
            count,
            name: name.unwrap_or_default(),
        });
    }
    info.bindings.sort_by_key(|b| (b.set, b.binding));
    Ok(info)
}
