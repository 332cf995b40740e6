//! Native code for a scheduled [`Code`]: the straight-line program compiled by Cranelift into
//! one machine function `f(x, force, value)` that reads the inputs from `x` and writes the
//! force components to `force` and U to `value` (those the code computes).
//!
//! A register machine that dispatches per instruction costs 2–3 ns an instruction for one
//! trajectory, several times the arithmetic (see docs/design.md); the compiled function keeps
//! every value in a register or a spill slot and costs what the arithmetic costs. It computes
//! the same bits as the interpreter: Cranelift emits each IEEE operation as written (it never
//! fuses a·b + c), square root and |x| are exact, and every libm function (exp, sin, pow, …) is
//! called through the very function the interpreter calls.

use std::sync::Arc;

use cranelift_codegen::ir::{types, AbiParam, InstBuilder, MemFlagsData, Signature, UserFuncName};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};

use super::program::{Binary, Code, Instr, Unary};

type Function = unsafe extern "C" fn(*const f64, *mut f64, *mut f64);

/// A compiled code: `call(x, force, value)`.
#[derive(Clone)]
pub struct Compiled {
    function: Function,
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
        write!(f, "Compiled({} → {})", self.n_inputs, self.n_force)
    }
}

impl Compiled {
    /// Runs the function: `force` gets the force components (when the code computes them),
    /// `value` gets U (when it computes it; left alone otherwise).
    #[inline(always)]
    pub fn call(&self, x: &[f64], force: &mut [f64], value: &mut f64) {
        assert!(x.len() >= self.n_inputs && force.len() >= self.n_force);
        // SAFETY: the function reads n_inputs doubles from x, writes n_force to force and at
        // most one to value, all checked just above; it touches no other memory.
        unsafe { (self.function)(x.as_ptr(), force.as_mut_ptr(), value) }
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

/// Compiles each code into one module; None where the host has no Cranelift back end (the
/// interpreter then runs, with the same bits).
pub fn compile(codes: &[&Code]) -> Option<Vec<Compiled>> {
    let mut flags = settings::builder();
    flags.set("opt_level", "speed").ok()?;
    flags.set("use_colocated_libcalls", "false").ok()?;
    flags.set("is_pic", "false").ok()?;
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
        sig.params.extend([AbiParam::new(ptr); 3]);
        let id = module
            .declare_function(&format!("code{k}"), Linkage::Local, &sig)
            .ok()?;
        ctx.func.signature = sig;
        ctx.func.name = UserFuncName::user(0, id.as_u32());
        emit(
            code,
            FunctionBuilder::new(&mut ctx.func, &mut fctx),
            &module,
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
                // (ptr, ptr, ptr) -> () of the platform's C convention.
                function: unsafe { std::mem::transmute::<*const u8, Function>(f) },
                n_inputs: code.n_inputs,
                n_force: code.force.as_ref().map_or(0, Vec::len),
                _module: owner.clone(),
            })
            .collect(),
    )
}

fn emit(code: &Code, mut b: FunctionBuilder<'_>, module: &JITModule) {
    let ptr = module.target_config().pointer_type();
    let entry = b.create_block();
    b.append_block_params_for_function_params(entry);
    b.switch_to_block(entry);
    let (x, force, value) = {
        let p = b.block_params(entry);
        (p[0], p[1], p[2])
    };
    let mem = MemFlagsData::trusted();
    let mut call_sig = |args: usize| {
        let mut s = Signature::new(module.isa().default_call_conv());
        s.params
            .extend((0..args).map(|_| AbiParam::new(types::F64)));
        s.returns.push(AbiParam::new(types::F64));
        b.import_signature(s)
    };
    let (sig1, sig2) = (call_sig(1), call_sig(2));
    let mut slot = Vec::with_capacity(code.n_inputs + code.constants.len() + code.instrs.len());
    for i in 0..code.n_inputs {
        slot.push(b.ins().load(types::F64, mem, x, (8 * i) as i32));
    }
    for &c in &code.constants {
        slot.push(b.ins().f64const(c));
    }
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
            Instr::Un(Unary::Neg, a) => b.ins().fneg(v(a)),
            Instr::Un(Unary::Sqrt, a) => b.ins().sqrt(v(a)),
            Instr::Un(Unary::Abs, a) => b.ins().fabs(v(a)),
            Instr::Un(op, a) => {
                let f = b.ins().iconst(ptr, callee(op) as usize as i64);
                let call = b.ins().call_indirect(sig1, f, &[v(a)]);
                b.inst_results(call)[0]
            }
            Instr::Powf(a, c) => {
                let f = b.ins().iconst(ptr, c_powf as *const () as usize as i64);
                let c = b.ins().f64const(c);
                let call = b.ins().call_indirect(sig2, f, &[v(a), c]);
                b.inst_results(call)[0]
            }
        };
        slot.push(r);
    }
    for (k, &s) in code.force.iter().flatten().enumerate() {
        b.ins().store(mem, slot[s as usize], force, (8 * k) as i32);
    }
    if let Some(s) = code.value {
        b.ins().store(mem, slot[s as usize], value, 0);
    }
    b.ins().return_(&[]);
    b.seal_all_blocks();
    b.finalize(module.target_config());
}
