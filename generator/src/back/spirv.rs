//! A reader of SPIR-V words that finds every function's branches: the
//! branch-free proof of docs/BOX_SPLINES.md §4 made again on the translated
//! code. It needs no naga back end, so it is built without the `targets`
//! feature too (the writer is [`super::spirv_writer`]).

use std::collections::BTreeMap;

const OP_NAME: u16 = 5;
const OP_ENTRY_POINT: u16 = 15;
const OP_FUNCTION: u16 = 54;
const OP_FUNCTION_END: u16 = 56;
const OP_FUNCTION_CALL: u16 = 57;
const OP_DECORATE: u16 = 71;
const OP_LOOP_MERGE: u16 = 246;
const OP_BRANCH_CONDITIONAL: u16 = 250;
const OP_SWITCH: u16 = 251;
const OP_KILL: u16 = 252;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
/// The SPIR-V magic number, first word of every module.
pub const MAGIC: u32 = 0x0723_0203;

/// One function of a SPIR-V module, as [`read`] finds it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpirvFunction {
    /// Its result id.
    pub id: u32,
    /// Its `OpName`, if any.
    pub name: Option<String>,
    /// `OpBranchConditional` and `OpSwitch` in its own body.
    pub branches: usize,
    /// `OpLoopMerge` (loops) in its own body.
    pub loops: usize,
    /// `OpKill` in its own body.
    pub kills: usize,
    /// Ids of the functions it calls, one per call site.
    pub calls: Vec<u32>,
}

/// A resource variable's decorations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpirvResource {
    /// Its `OpName`, if any.
    pub name: Option<String>,
    /// `DescriptorSet`.
    pub set: u32,
    /// `Binding`.
    pub binding: u32,
}

/// What [`read`] finds in a module.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SpirvModule {
    /// Every function, in order.
    pub functions: Vec<SpirvFunction>,
    /// Entry point names.
    pub entry_points: Vec<String>,
    /// Every variable with a descriptor set and binding.
    pub resources: Vec<SpirvResource>,
}

impl SpirvModule {
    /// Branches (`OpBranchConditional`, `OpSwitch`), loops and kills over
    /// the call tree of the function named `name`, or None without one.
    pub fn call_tree_branches(&self, name: &str) -> Option<usize> {
        let by_id: BTreeMap<u32, &SpirvFunction> = self.functions.iter().map(|f| (f.id, f)).collect();
        let root = self.functions.iter().find(|f| f.name.as_deref() == Some(name))?;
        let mut total = 0;
        let mut stack = vec![(root, 0usize)];
        while let Some((f, depth)) = stack.pop() {
            if depth > self.functions.len() {
                return Some(usize::MAX); // recursion: not a valid shader, never branch-free
            }
            total += f.branches + f.loops + f.kills;
            stack.extend(f.calls.iter().filter_map(|c| by_id.get(c)).map(|g| (*g, depth + 1)));
        }
        Some(total)
    }
}

fn string_at(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Reads the instructions of a SPIR-V binary: functions with their own
/// branches and calls, entry points, descriptor bindings.
///
/// # Errors
///
/// A message for a binary that is not SPIR-V or is cut short.
pub fn read(words: &[u32]) -> Result<SpirvModule, String> {
    if words.len() < 5 || words[0] != MAGIC {
        return Err("not a SPIR-V module (no magic number)".into());
    }
    let mut names: BTreeMap<u32, String> = BTreeMap::new();
    let mut sets: BTreeMap<u32, u32> = BTreeMap::new();
    let mut bindings: BTreeMap<u32, u32> = BTreeMap::new();
    let mut m = SpirvModule::default();
    let mut current: Option<SpirvFunction> = None;
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let op = (words[at] & 0xffff) as u16;
        if count == 0 || at + count > words.len() {
            return Err(format!("instruction at word {at} runs past the end of the module"));
        }
        let w = &words[at..at + count];
        match op {
            OP_NAME if count >= 3 => {
                names.insert(w[1], string_at(&w[2..]));
            }
            OP_ENTRY_POINT if count >= 4 => m.entry_points.push(string_at(&w[3..])),
            OP_DECORATE if count >= 4 && w[2] == DECORATION_DESCRIPTOR_SET => {
                sets.insert(w[1], w[3]);
            }
            OP_DECORATE if count >= 4 && w[2] == DECORATION_BINDING => {
                bindings.insert(w[1], w[3]);
            }
            OP_FUNCTION if count >= 3 => {
                current = Some(SpirvFunction { id: w[2], name: None, branches: 0, loops: 0, kills: 0, calls: vec![] });
            }
            OP_FUNCTION_END => m.functions.extend(current.take()),
            OP_FUNCTION_CALL if count >= 4 => {
                if let Some(f) = current.as_mut() {
                    f.calls.push(w[3]);
                }
            }
            OP_BRANCH_CONDITIONAL | OP_SWITCH => {
                if let Some(f) = current.as_mut() {
                    f.branches += 1;
                }
            }
            OP_LOOP_MERGE => {
                if let Some(f) = current.as_mut() {
                    f.loops += 1;
                }
            }
            OP_KILL => {
                if let Some(f) = current.as_mut() {
                    f.kills += 1;
                }
            }
            _ => {}
        }
        at += count;
    }
    if current.is_some() {
        return Err("a function has no OpFunctionEnd".into());
    }
    for f in &mut m.functions {
        f.name = names.get(&f.id).cloned();
    }
    for (id, set) in &sets {
        if let Some(&binding) = bindings.get(id) {
            m.resources.push(SpirvResource { name: names.get(id).cloned(), set: *set, binding });
        }
    }
    Ok(m)
}
