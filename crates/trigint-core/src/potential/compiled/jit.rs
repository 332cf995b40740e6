//! Native code for a scheduled [`Code`]: the straight-line program compiled by Cranelift into
//! one machine function `f(x, force, value, count)` that reads the inputs from `x` and writes
//! the force components to `force` and U to `value` (those the code computes), once or over
//! `count` evaluations two at a time ([`Walk`]).
//!
//! A register machine that dispatches per instruction costs 2–3 ns an instruction for one
//! trajectory, several times the arithmetic (see docs/design.md); the compiled function keeps
//! every value in a register or a spill slot and costs what the arithmetic costs. It computes
//! the same bits as the interpreter: Cranelift emits each IEEE operation as written (it never
//! fuses a·b + c), square root and |x| are exact, and every libm function (exp, sin, pow, …) is
//! called through the very function the interpreter calls.

use std::sync::Arc;

use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::{
    types, AbiParam, BlockArg, ConstantData, InstBuilder, MemFlagsData, Signature, StackSlotData,
    StackSlotKind, Type, UserFuncName, Value,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};

use super::code::{Code, Instr};
use super::libm::SIN_COS_C;
use super::ops::{Binary, Unary};

type Function = unsafe extern "C" fn(*const f64, *mut f64, *mut f64, usize);

/// How a compiled function walks its numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walk {
    /// One evaluation: input i at `x[i]`, force component k at `force[k]`, U at `value[0]`.
    One,
    /// `count` evaluations (count even), two at a time in 128-bit registers: input i of
    /// evaluation j at `x[i * stride + j]`, force k at `force[k * stride + j]`, U at `value[j]`.
    /// A bundle of W lanes is `stride = count = W`; one univariate code over many arguments
    /// (a chain's springs) is any stride with `count` the number of arguments.
    Pairs { stride: usize },
}

/// A compiled code: `call(x, force, value)` or `call_pairs(x, force, value, count)`.
#[derive(Clone)]
pub struct Compiled {
    function: Function,
    walk: Walk,
    n_inputs: usize,
    n_force: usize,
    /// Owns the executable memory `function` points into.
    _module: Arc<ModuleOwner>,
}

struct ModuleOwner(#[allow(dead_code)] JITModule);

// SAFETY: after `finalize_definitions` the module is never touched again; it only keeps the
// executable memory alive. The compiled functions are pure (they read `x`, write `out`).
unsafe impl Send for ModuleOwner {}
unsafe impl Sync for ModuleOwner {}

impl std::fmt::Debug for Compiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Compiled({} → {}, {:?})",
            self.n_inputs, self.n_force, self.walk
        )
    }
}

impl Compiled {
    /// Runs a [`Walk::One`] function: `force` gets the force components (when the code
    /// computes them), `value` gets U (when it computes it; left alone otherwise).
    #[inline(always)]
    pub fn call(&self, x: &[f64], force: &mut [f64], value: &mut f64) {
        assert!(self.walk == Walk::One);
        assert!(x.len() >= self.n_inputs && force.len() >= self.n_force);
        // SAFETY: the function reads n_inputs doubles from x, writes n_force to force and at
        // most one to value, all checked just above; it touches no other memory.
        unsafe { (self.function)(x.as_ptr(), force.as_mut_ptr(), value, 0) }
    }

    /// Runs a [`Walk::Pairs`] function over `count` (even) evaluations.
    #[inline(always)]
    pub fn call_pairs(&self, x: &[f64], force: &mut [f64], value: &mut [f64], count: usize) {
        let Walk::Pairs { stride } = self.walk else {
            panic!("not a function over pairs")
        };
        let span = |rows: usize| {
            if rows == 0 {
                0
            } else {
                (rows - 1) * stride + count
            }
        };
        assert!(count.is_multiple_of(2), "an even number of evaluations");
        assert!(x.len() >= span(self.n_inputs) && force.len() >= span(self.n_force));
        assert!(value.len() >= count);
        // SAFETY: the function reads x[i·stride + j] for i < n_inputs, j < count, writes the
        // same pattern of force for k < n_force and value[j] (the last only when it computes
        // U): all inside the lengths checked above.
        unsafe { (self.function)(x.as_ptr(), force.as_mut_ptr(), value.as_mut_ptr(), count) }
    }
}

// The libm functions as the C ABI calls them; each body is the interpreter's own function.
macro_rules! c_unary {
    ($($name:ident => $op:expr),* $(,)?) => {
        $(extern "C" fn $name(x: f64) -> f64 {
            ($op.scalar())(x)
        })*
    };
}
c_unary!(
    c_exp => Unary::Exp, c_log => Unary::Log, c_sin => Unary::Sin, c_cos => Unary::Cos,
    c_tan => Unary::Tan, c_sinh => Unary::Sinh, c_cosh => Unary::Cosh, c_tanh => Unary::Tanh,
    c_sign => Unary::Sign,
);

extern "C" fn c_powf(a: f64, c: f64) -> f64 {
    f64::powf(a, c)
}

fn callee(op: Unary) -> extern "C" fn(f64) -> f64 {
    match op {
        Unary::Exp => c_exp,
        Unary::Log => c_log,
        Unary::Sin => c_sin,
        Unary::Cos => c_cos,
        Unary::Tan => c_tan,
        Unary::Sinh => c_sinh,
        Unary::Cosh => c_cosh,
        Unary::Tanh => c_tanh,
        Unary::Sign => c_sign,
        Unary::Neg | Unary::Sqrt | Unary::Abs => unreachable!("emitted inline"),
    }
}

/// Compiles each code into one module, every function walking its numbers as `walk` says;
/// None where the host has no Cranelift back end (the interpreter then runs, with the same
/// bits).
pub fn compile(codes: &[&Code], walk: Walk) -> Option<Vec<Compiled>> {
    let mut flags = settings::builder();
    flags.set("opt_level", "speed").ok()?;
    flags.set("use_colocated_libcalls", "false").ok()?;
    flags.set("is_pic", "false").ok()?;
    // Cranelift checks its IR by default: the debug build (the Rust tests) keeps the check for
    // the emitter; a release build skips it (about a fifth of a large program's compile time)
    let verify = if cfg!(debug_assertions) {
        "true"
    } else {
        "false"
    };
    flags.set("enable_verifier", verify).ok()?;
    let isa = cranelift_native::builder()
        .ok()?
        .finish(settings::Flags::new(flags))
        .ok()?;
    let mut module = JITModule::new(JITBuilder::with_isa(isa, default_libcall_names()));
    let ptr = module.target_config().pointer_type();
    let mut ids = Vec::new();
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    for (k, code) in codes.iter().enumerate() {
        let mut sig = module.make_signature();
        sig.params.extend([AbiParam::new(ptr); 4]);
        let id = module
            .declare_function(&format!("code{k}"), Linkage::Local, &sig)
            .ok()?;
        ctx.func.signature = sig;
        ctx.func.name = UserFuncName::user(0, id.as_u32());
        emit(
            code,
            FunctionBuilder::new(&mut ctx.func, &mut fctx),
            &module,
            walk,
        );
        module.define_function(id, &mut ctx).ok()?;
        module.clear_context(&mut ctx);
        ids.push(id);
    }
    module.finalize_definitions().ok()?;
    let functions: Vec<_> = ids
        .iter()
        .map(|&id| module.get_finalized_function(id))
        .collect();
    let owner = Arc::new(ModuleOwner(module));
    Some(
        codes
            .iter()
            .zip(functions)
            .map(|(code, f)| Compiled {
                // SAFETY: the function was defined above with the signature
                // (ptr, ptr, ptr, ptr) -> () of the platform's C convention.
                function: unsafe { std::mem::transmute::<*const u8, Function>(f) },
                walk,
                n_inputs: code.n_inputs,
                n_force: code.force.as_ref().map_or(0, Vec::len),
                _module: owner.clone(),
            })
            .collect(),
    )
}

/// The function's frame: one pass of the code, or a loop that runs it on evaluations
/// (j, j + 1) for j = 0, 2, …, count − 2 with the pointers advanced by 16 bytes a pass.
fn emit(code: &Code, mut b: FunctionBuilder<'_>, module: &JITModule, walk: Walk) {
    let ptr = module.target_config().pointer_type();
    let entry = b.create_block();
    b.append_block_params_for_function_params(entry);
    b.switch_to_block(entry);
    let p: Vec<Value> = b.block_params(entry).to_vec();
    let (x, force, value, count) = (p[0], p[1], p[2], p[3]);
    match walk {
        Walk::One => {
            let at = Access {
                x,
                force,
                value,
                row: 8,
                ty: types::F64,
                constants: constants(code, &mut b, types::F64),
                sign: None,
            };
            emit_pass(code, &mut b, module, &at);
            b.ins().return_(&[]);
        }
        Walk::Pairs { stride } => {
            // Two pairs a pass while four evaluations remain, then the last pair alone. The
            // constants and the sign mask are made once, before the loop.
            let at =
                |b: &mut FunctionBuilder<'_>, offset: Value, consts: &(Vec<Value>, Value)| Access {
                    x: b.ins().iadd(x, offset),
                    force: b.ins().iadd(force, offset),
                    value: b.ins().iadd(value, offset),
                    row: 8 * stride as i32,
                    ty: types::F64X2,
                    constants: consts.0.clone(),
                    sign: Some(consts.1),
                };
            let consts = (
                constants(code, &mut b, types::F64X2),
                vector_constant(&mut b, -0.0),
            );
            let end = b.ins().ishl_imm_u(count, 3);
            let zero = b.ins().iconst(ptr, 0);
            let [twice, body2, once, body1, exit] = std::array::from_fn(|_| b.create_block());
            let offset2 = b.append_block_param(twice, ptr);
            let offset1 = b.append_block_param(once, ptr);
            b.ins().jump(twice, &[BlockArg::Value(zero)]);

            b.switch_to_block(twice);
            let after = b.ins().iadd_imm_u(offset2, 32);
            let room = b.ins().icmp(IntCC::UnsignedLessThanOrEqual, after, end);
            b.ins()
                .brif(room, body2, &[], once, &[BlockArg::Value(offset2)]);
            b.switch_to_block(body2);
            let first = at(&mut b, offset2, &consts);
            emit_pass(code, &mut b, module, &first);
            let second_offset = b.ins().iadd_imm_u(offset2, 16);
            let second = at(&mut b, second_offset, &consts);
            emit_pass(code, &mut b, module, &second);
            b.ins().jump(twice, &[BlockArg::Value(after)]);

            b.switch_to_block(once);
            let more = b.ins().icmp(IntCC::UnsignedLessThan, offset1, end);
            b.ins().brif(more, body1, &[], exit, &[]);
            b.switch_to_block(body1);
            let last = at(&mut b, offset1, &consts);
            emit_pass(code, &mut b, module, &last);
            b.ins().jump(exit, &[]);

            b.switch_to_block(exit);
            b.ins().return_(&[]);
        }
    }
    b.seal_all_blocks();
    b.finalize(module.target_config());
}

/// Where a pass reads and writes: input i at `x + i·row`, force k at `force + k·row`, U at
/// `value`, each a number of type `ty` (one double, or two).
/// `constants` are the code's constants as values of `ty`; `sign` (pairs) the mask −0.0 whose
/// XOR negates.
struct Access {
    x: Value,
    force: Value,
    value: Value,
    row: i32,
    ty: Type,
    constants: Vec<Value>,
    sign: Option<Value>,
}

/// `c` in both lanes of a 128-bit register.
fn vector_constant(b: &mut FunctionBuilder<'_>, c: f64) -> Value {
    let bytes: Vec<u8> = [c, c].iter().flat_map(|v| v.to_le_bytes()).collect();
    let handle = b.func.dfg.constants.insert(ConstantData::from(bytes));
    b.ins().vconst(types::F64X2, handle)
}

/// The code's constants as values of type `ty`.
fn constants(code: &Code, b: &mut FunctionBuilder<'_>, ty: Type) -> Vec<Value> {
    code.constants
        .iter()
        .map(|&c| {
            if ty == types::F64 {
                b.ins().f64const(c)
            } else {
                vector_constant(b, c)
            }
        })
        .collect()
}

/// The straight-line code once, on one double or on two lanes at a time: IEEE operations as
/// vector instructions (the same bits lane by lane), libm functions called per lane.
fn emit_pass(code: &Code, b: &mut FunctionBuilder<'_>, module: &JITModule, at: &Access) {
    let ptr = module.target_config().pointer_type();
    let mem = MemFlagsData::new().with_notrap();
    let mut call_sig = |args: usize| {
        let mut s = Signature::new(module.isa().default_call_conv());
        s.params
            .extend((0..args).map(|_| AbiParam::new(types::F64)));
        s.returns.push(AbiParam::new(types::F64));
        b.import_signature(s)
    };
    let (sig1, sig2) = (call_sig(1), call_sig(2));
    let sig_sincos = {
        let mut s = Signature::new(module.isa().default_call_conv());
        s.params.extend([
            AbiParam::new(types::F64),
            AbiParam::new(ptr),
            AbiParam::new(ptr),
        ]);
        b.import_signature(s)
    };
    let pair_slot =
        b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 16, 3));
    let vector = at.ty != types::F64;
    // (sin a, cos a) through a stack slot (two doubles come back in registers on some
    // platforms, through a hidden pointer on others), per lane for a pair.
    let sincos = |b: &mut FunctionBuilder<'_>, a: Value| -> (Value, Value) {
        let f = b.ins().iconst(ptr, SIN_COS_C as *const () as i64);
        let one = |b: &mut FunctionBuilder<'_>, a: Value| -> (Value, Value) {
            let sin = b.ins().stack_addr(ptr, pair_slot, 0);
            let cos = b.ins().stack_addr(ptr, pair_slot, 8);
            b.ins().call_indirect(sig_sincos, f, &[a, sin, cos]);
            (
                b.ins().stack_load(ptr, types::F64, pair_slot, 0),
                b.ins().stack_load(ptr, types::F64, pair_slot, 8),
            )
        };
        if !vector {
            return one(b, a);
        }
        let (a0, a1) = (b.ins().extractlane(a, 0), b.ins().extractlane(a, 1));
        let (s0, c0) = one(b, a0);
        let (s1, c1) = one(b, a1);
        let (s, c) = (
            b.ins().splat(types::F64X2, s0),
            b.ins().splat(types::F64X2, c0),
        );
        (b.ins().insertlane(s, s1, 1), b.ins().insertlane(c, c1, 1))
    };
    // f(a) or f(a, c) with f a C function of doubles: per lane for a pair.
    let call = |b: &mut FunctionBuilder<'_>, f: usize, a: Value, c: Option<f64>| -> Value {
        let f = b.ins().iconst(ptr, f as i64);
        let one = |b: &mut FunctionBuilder<'_>, a: Value| -> Value {
            let call = match c {
                None => b.ins().call_indirect(sig1, f, &[a]),
                Some(c) => {
                    let c = b.ins().f64const(c);
                    b.ins().call_indirect(sig2, f, &[a, c])
                }
            };
            b.inst_results(call)[0]
        };
        if !vector {
            return one(b, a);
        }
        let (a0, a1) = (b.ins().extractlane(a, 0), b.ins().extractlane(a, 1));
        let (r0, r1) = (one(b, a0), one(b, a1));
        let r = b.ins().splat(types::F64X2, r0);
        b.ins().insertlane(r, r1, 1)
    };
    let mut slot = Vec::with_capacity(code.n_inputs + code.constants.len() + code.instrs.len());
    for i in 0..code.n_inputs {
        slot.push(b.ins().load(at.ty, mem, at.x, at.row * i as i32));
    }
    slot.extend_from_slice(&at.constants);
    let mut cos_next = None;
    for ins in &code.instrs {
        let v = |s: u32| slot[s as usize];
        let r = match *ins {
            Instr::Bin(op, a, c) => {
                let (a, c) = (v(a), v(c));
                match op {
                    Binary::Add => b.ins().fadd(a, c),
                    Binary::Sub => b.ins().fsub(a, c),
                    Binary::Mul => b.ins().fmul(a, c),
                    Binary::Div => b.ins().fdiv(a, c),
                }
            }
            Instr::Un(Unary::Neg, a) => match at.sign {
                Some(sign) => b.ins().bxor(v(a), sign),
                None => b.ins().fneg(v(a)),
            },
            Instr::Un(Unary::Sqrt, a) => b.ins().sqrt(v(a)),
            Instr::Un(Unary::Abs, a) => b.ins().fabs(v(a)),
            Instr::Un(op, a) => call(b, callee(op) as usize, v(a), None),
            Instr::Powf(a, c) => call(b, c_powf as *const () as usize, v(a), Some(c)),
            Instr::SinCos(a) => {
                let (sin, cos) = sincos(b, v(a));
                cos_next = Some(cos);
                sin
            }
            Instr::Filled => cos_next.take().expect("a SinCos comes before"),
        };
        slot.push(r);
    }
    for (k, &s) in code.force.iter().flatten().enumerate() {
        b.ins()
            .store(mem, slot[s as usize], at.force, at.row * k as i32);
    }
    if let Some(s) = code.value {
        b.ins().store(mem, slot[s as usize], at.value, 0);
    }
}
