//! The energy channels, written once: their names, forms and whether there is one per
//! oscillatory block. Everything else reads this table: the output order of the energy rows and
//! extremes, the channel names of the Python layer (exported as `_core.CHANNELS`), and the index
//! constants the kernels use ([`TOTAL`], …). A new streamed invariant is a new entry here plus
//! its form: a per-coordinate term in [`crate::energy`] summed by the observing sweep, or, for a
//! bilinear form Σ w (q_a p_b − q_b p_a) such as a momentum, a [`crate::energy::PairForms`]
//! that the problem's layout carries (the momentum entry below is nothing more).
//!
//! Paper §2.1 and (3.4): H = H_ω + H_slow, H_ω = Σ_j I_j, H*_ω (or H*_ω̃ for the modified
//! methods).

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
}

/// The channels in output order: the whole-state channels, then the per-block ones.
pub const CHANNELS: [Channel; 6] = [
    Channel {
        name: "total",
        form: "H = H_omega + H_slow",
        per_block: false,
        per_axis: false,
    },
    Channel {
        name: "oscillatory",
        form: "H_omega = sum_j I_j",
        per_block: false,
        per_axis: false,
    },
    Channel {
        name: "slow",
        form: "H_slow = |p_0|^2/2 + U(q)",
        per_block: false,
        per_axis: false,
    },
    Channel {
        name: "modified_oscillatory",
        form: "H*_omega = sum_i (a_i p_i^2 + b_i q_i^2)/2, paper (3.4)",
        per_block: false,
        per_axis: false,
    },
    Channel {
        name: "oscillatory",
        form: "I_j = sum_(i in block j) (p_i^2 + omega_i^2 q_i^2)/2",
        per_block: true,
        per_axis: false,
    },
    Channel {
        name: "momentum",
        form:
            "K_m = sum_k w_mk (q_a p_b - q_b p_a) over the pairs (a, b) of the layout's pair form",
        per_block: false,
        per_axis: true,
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
                "oscillatory_1",
                "oscillatory_2"
            ]
        );
        assert_eq!(
            (TOTAL, OSCILLATORY, SLOW, MODIFIED, FIRST_BLOCK),
            (0, 1, 2, 3, 4)
        );
        assert_eq!(channel_count(0, 0), 4);
        for (blocks, axes) in [(0, 0), (1, 0), (7, 3), (32769, 1)] {
            assert_eq!(
                channel_count(blocks, axes),
                channel_names(blocks, axes).len()
            );
        }
        assert_eq!(channel_names(1, 2)[5..], ["momentum_1", "momentum_2"]);
    }
}
