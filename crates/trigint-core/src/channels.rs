//! The energy channels, written once: their names, forms, values and whether there is one per
//! oscillatory block. Everything else reads this table: the output order of the energy rows and
//! extremes, the channel names of the Python layer (exported as `_core.CHANNELS`), the index
//! constants the kernels use ([`TOTAL`], …), and the value of every whole-state channel, which
//! every path (one trajectory, lanes, the wave equation, the Krylov step, `ti.energies`) computes
//! from the observing sweep's sums ([`crate::energy::Sums::channels`]).
//!
//! A new whole-state channel that combines the sweep's sums is one entry here. One that needs a
//! new per-coordinate form is an entry here, a [`sum`] index and its term in the sweep
//! ([`crate::energy`], `recursion/mod.rs`). A bilinear form Σ w (q_a p_b − q_b p_a) such as a
//! momentum is a [`crate::energy::PairForms`] that the problem's layout carries (the momentum
//! entry below is nothing more).
//!
//! Paper §2.1 and (3.4): H = H_ω + H_slow, H_ω = Σ_j I_j, H*_ω (or H*_ω̃ for the modified
//! methods).

/// The sums the observing sweep accumulates over a state, each of a per-coordinate quadratic
/// form ([`crate::energy::Sums`] is indexed by these).
pub mod sum {
    /// Σ p² over the slow coordinates ([`crate::energy::kinetic`])
    pub const KINETIC: usize = 0;
    /// Σ (p² + ω²q²) over the oscillatory coordinates ([`crate::energy::oscillator`])
    pub const OSCILLATOR: usize = 1;
    /// Σ (a p² + b q²) over the oscillatory coordinates, paper (3.4)
    /// ([`crate::energy::modified`]); where H* is H_ω the sweep skips it and the oscillator sum
    /// stands in
    pub const MODIFIED: usize = 2;
    /// Number of sums.
    pub const COUNT: usize = 3;
}

/// A whole-state channel's value from the sweep's sums s and the potential U:
/// ½ s\[halves\[0\]\] + (½ s\[halves\[1\]\] + (… + U)), the innermost term U only with `potential`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Value {
    /// The sums taken, each halved, added from the last to the first.
    pub halves: &'static [usize],
    /// U(q) added innermost.
    pub potential: bool,
}

/// One channel of the energy output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Channel {
    /// The output name (`sol.energies[name]`); per-block channels are `name_1` … `name_ℓ`.
    pub name: &'static str,
    /// The formula, as the documentation states it.
    pub form: &'static str,
    /// One channel per oscillatory block rather than one for the whole state.
    pub per_block: bool,
    /// One channel per axis of a pair form (present only for problems that have one, such as
    /// the momentum of a wave equation); these come after the per-block channels.
    pub per_axis: bool,
    /// How a whole-state channel is computed from the sums (None for the per-block and
    /// per-axis channels: the sweep's per-block sums, halved, and the pair forms).
    pub value: Option<Value>,
}

/// The channels in output order: the whole-state channels, then the per-block ones.
pub const CHANNELS: [Channel; 7] = [
    Channel {
        name: "total",
        form: "H = H_omega + H_slow",
        per_block: false,
        per_axis: false,
        value: Some(Value {
            halves: &[sum::OSCILLATOR, sum::KINETIC],
            potential: true,
        }),
    },
    Channel {
        name: "oscillatory",
        form: "H_omega = sum_j I_j",
        per_block: false,
        per_axis: false,
        value: Some(Value {
            halves: &[sum::OSCILLATOR],
            potential: false,
        }),
    },
    Channel {
        name: "slow",
        form: "H_slow = |p_0|^2/2 + U(q)",
        per_block: false,
        per_axis: false,
        value: Some(Value {
            halves: &[sum::KINETIC],
            potential: true,
        }),
    },
    Channel {
        name: "modified_oscillatory",
        form: "H*_omega = sum_i (a_i p_i^2 + b_i q_i^2)/2, paper (3.4)",
        per_block: false,
        per_axis: false,
        value: Some(Value {
            halves: &[sum::MODIFIED],
            potential: false,
        }),
    },
    Channel {
        name: "kinetic",
        form: "T_slow = |p_0|^2/2, the kinetic part of H_slow",
        per_block: false,
        per_axis: false,
        value: Some(Value {
            halves: &[sum::KINETIC],
            potential: false,
        }),
    },
    Channel {
        name: "oscillatory",
        form: "I_j = sum_(i in block j) (p_i^2 + omega_i^2 q_i^2)/2",
        per_block: true,
        per_axis: false,
        value: None,
    },
    Channel {
        name: "momentum",
        form:
            "K_m = sum_k w_mk (q_a p_b - q_b p_a) over the pairs (a, b) of the layout's pair form",
        per_block: false,
        per_axis: true,
        value: None,
    },
];

const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// Index of the whole-state channel `name` (a compile-time error if there is none).
const fn index(name: &str) -> usize {
    let mut i = 0;
    while i < CHANNELS.len() {
        if !CHANNELS[i].per_block && !CHANNELS[i].per_axis && same(CHANNELS[i].name, name) {
            return i;
        }
        i += 1;
    }
    panic!("no such channel")
}

/// Number of whole-state channels; the per-block ones follow them.
pub const FIRST_BLOCK: usize = {
    let mut i = 0;
    while i < CHANNELS.len() && !CHANNELS[i].per_block && !CHANNELS[i].per_axis {
        i += 1;
    }
    i
};
// Every whole-state channel has a value and comes before the per-block and per-axis ones, which
// have none (checked when the crate compiles).
const _: () = {
    let mut i = 0;
    while i < CHANNELS.len() {
        assert!(CHANNELS[i].value.is_some() == (i < FIRST_BLOCK));
        i += 1;
    }
};
pub const TOTAL: usize = index("total");
pub const OSCILLATORY: usize = index("oscillatory");
pub const SLOW: usize = index("slow");
pub const MODIFIED: usize = index("modified_oscillatory");

/// Number of output channels for ℓ oscillatory blocks and a pair form of `n_axes` axes.
pub fn channel_count(n_blocks: usize, n_axes: usize) -> usize {
    // counted, not formatted: a wave equation on 2^16 points has 32 769 per-block names, and
    // formatting them took a third of a short run's fixed cost
    CHANNELS
        .iter()
        .map(|c| match (c.per_block, c.per_axis) {
            (true, _) => n_blocks,
            (_, true) => n_axes,
            _ => 1,
        })
        .sum()
}

/// The channel names in output order for ℓ oscillatory blocks and a pair form of `n_axes`
/// axes (0: none): the whole-state channels, the per-block ones, then the per-axis ones.
pub fn channel_names(n_blocks: usize, n_axes: usize) -> Vec<String> {
    let mut names = Vec::new();
    for c in CHANNELS.iter().filter(|c| !c.per_block && !c.per_axis) {
        names.push(c.name.to_string());
    }
    for c in CHANNELS.iter().filter(|c| c.per_block) {
        names.extend((1..=n_blocks).map(|j| format!("{}_{j}", c.name)));
    }
    for c in CHANNELS.iter().filter(|c| c.per_axis) {
        names.extend((1..=n_axes).map(|j| format!("{}_{j}", c.name)));
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_gives_the_documented_order() {
        assert_eq!(
            channel_names(2, 0),
            [
                "total",
                "oscillatory",
                "slow",
                "modified_oscillatory",
                "kinetic",
                "oscillatory_1",
                "oscillatory_2"
            ]
        );
        assert_eq!(
            (TOTAL, OSCILLATORY, SLOW, MODIFIED, FIRST_BLOCK),
            (0, 1, 2, 3, 5)
        );
        assert_eq!(channel_count(0, 0), 5);
        for (blocks, axes) in [(0, 0), (1, 0), (7, 3), (32769, 1)] {
            assert_eq!(
                channel_count(blocks, axes),
                channel_names(blocks, axes).len()
            );
        }
        assert_eq!(channel_names(1, 2)[6..], ["momentum_1", "momentum_2"]);
    }
}
