//! What the CPU is: its model name and the instruction sets the kernels' copies use.

/// The CPU's model name as it gives it (x86-64: CPUID's brand string), or the architecture.
pub fn model() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::__cpuid;
        // Leaf 0x8000_0000 says which extended leaves the CPU has.
        let top = __cpuid(0x8000_0000).eax;
        if top >= 0x8000_0004 {
            let mut bytes = Vec::with_capacity(48);
            for leaf in 0x8000_0002u32..=0x8000_0004 {
                let r = __cpuid(leaf);
                for word in [r.eax, r.ebx, r.ecx, r.edx] {
                    bytes.extend_from_slice(&word.to_le_bytes());
                }
            }
            let text = String::from_utf8_lossy(&bytes);
            let name = text.trim_matches(char::from(0)).trim();
            if !name.is_empty() {
                return name.split_whitespace().collect::<Vec<_>>().join(" ");
            }
        }
    }
    std::env::consts::ARCH.to_string()
}

/// The instruction sets this CPU has, of those the kernels are compiled for.
pub fn features() -> Vec<&'static str> {
    let mut out = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            out.push("avx2");
        }
        for (name, has) in [
            ("avx512f", std::is_x86_feature_detected!("avx512f")),
            ("avx512vl", std::is_x86_feature_detected!("avx512vl")),
            ("avx512dq", std::is_x86_feature_detected!("avx512dq")),
        ] {
            if has {
                out.push(name);
            }
        }
    }
    out
}

/// Whether the CPU is AMD's (CPUID's vendor string "AuthenticAMD"). AMD's cores pay nothing for
/// mixing legacy-SSE and VEX-encoded code (Intel's may: see `isa::run`), so there the baseline
/// copy is one more candidate for the planner.
pub fn is_amd() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::__cpuid;
        let r = __cpuid(0);
        let mut vendor = Vec::with_capacity(12);
        for word in [r.ebx, r.edx, r.ecx] {
            vendor.extend_from_slice(&word.to_le_bytes());
        }
        vendor == b"AuthenticAMD"
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A hash of the model and the features (FNV-1a: the same on every build), so that machines
/// that share a home directory keep their plans apart.
pub fn fingerprint() -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let text = format!("{}|{}", model(), features().join(","));
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}
