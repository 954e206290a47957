//! The devices `fxshade synth --device` places on: a part of a target's
//! family (the family fixes the cells Yosys maps to and the delay model;
//! the part fixes its size and the placer's arguments), and how much of it
//! a design uses.
//!
//! For a placed design the utilisation is the placer's own report (its
//! used and available counts per resource); a family without an open
//! placer (Xilinx 7-series) is compared with the part's capacity from the
//! vendor's product table (AMD/Xilinx DS180, "7 Series FPGAs Data Sheet:
//! Overview", Artix-7 table: logic cells as 6-input LUTs, flip-flops,
//! DSP48E1 slices, 36 Kb block RAMs counted as two 18 Kb halves).

use crate::synth::Target;
use fxshade_model::convert::to_f64;

/// One part of a family (the family's file in
/// `fxshade_model::rtl::targets` lists its parts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Device {
    /// Its name as `--device` takes it (case-insensitive) and as reported.
    pub name: &'static str,
    /// The family it belongs to.
    pub target: Target,
    /// The placer's device and package arguments (none: no open placer).
    pub pnr_args: &'static [&'static str],
    /// Capacity by resource where no placer reports it: (LUT, FF, DSP,
    /// block RAM in 18 Kb halves).
    pub capacity: Option<[u64; 4]>,
}

/// Every part `--device` takes, family by family.
pub fn devices() -> impl Iterator<Item = Device> {
    Target::all()
        .iter()
        .flat_map(|t| t.parts().iter().map(|p| Device::of(*t, *p)))
}

impl Device {
    fn of(target: Target, p: fxshade_model::rtl::targets::Part) -> Device {
        Device {
            name: p.name,
            target,
            pnr_args: p.pnr_args,
            capacity: p.capacity,
        }
    }

    /// The default part of `target`'s family (None: generic synthesis,
    /// or a 7-series run given no part).
    pub fn default_of(target: Target) -> Option<Device> {
        target.default_part().map(|p| Device::of(target, p))
    }

    /// The part as reported: family, part and package, e.g. `ECP5
    /// LFE5U-25F (CABGA381)`.
    pub fn describe(&self) -> String {
        let family = self.target.part_prefix();
        match self.pnr_args.get(2) {
            Some(package) => format!("{family}{} ({package})", self.name),
            None => format!("{family}{}", self.name),
        }
    }

    /// The part named `name` (case-insensitive) of `target`'s family; an
    /// error lists the family's parts.
    ///
    /// # Errors
    ///
    /// `Err` naming the parts of `target`'s family when it has no part `name`.
    pub fn find(target: Target, name: &str) -> Result<Device, String> {
        let family: Vec<Device> = devices().filter(|d| d.target == target).collect();
        if family.is_empty() {
            return Err(format!(
                "--device {name}: --target {} has no device to choose",
                target.name()
            ));
        }
        family
            .iter()
            .find(|d| d.name.eq_ignore_ascii_case(name))
            .copied()
            .ok_or_else(|| {
                format!(
                    "--device {name}: not a part of --target {} (its parts: {})",
                    target.name(),
                    family.iter().map(|d| d.name).collect::<Vec<_>>().join(", ")
                )
            })
    }
}

/// One resource's use.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Use {
    /// The resource, as the placer (or the capacity table) names it.
    pub resource: String,
    /// Used.
    pub used: u64,
    /// Available on the part.
    pub available: u64,
    /// `100 · used / available`.
    pub percent: f64,
}

impl Use {
    /// `used` of `available`.
    pub fn new(resource: &str, used: u64, available: u64) -> Use {
        Use {
            resource: resource.to_string(),
            used,
            available,
            percent: if available == 0 {
                f64::INFINITY
            } else {
                100.0 * to_f64(used) / to_f64(available)
            },
        }
    }
}

/// The utilisation a placer's log reports, the resources the design uses
/// (a resource at 0 is left out).
pub fn placed(log: &str) -> Vec<Use> {
    crate::synth::utilisation(log)
        .into_iter()
        .filter(|(_, used, _)| *used > 0)
        .map(|(n, used, avail)| Use::new(&n, used, avail))
        .collect()
}

/// The utilisation of a part with a capacity table, from synthesis's
/// counts: LUTs, flip-flops, DSP blocks and block RAM in 18 Kb halves.
pub fn from_capacity(d: &Device, lut: u64, ff: u64, dsp: u64, bram18: u64) -> Vec<Use> {
    let Some([l, f, m, b]) = d.capacity else {
        return Vec::new();
    };
    // The family's multiplier block as its synthesis names it.
    let block = d
        .target
        .synthesis()
        .and_then(|s| s.dsp.first().copied())
        .unwrap_or("DSP");
    vec![
        Use::new("LUT", lut, l),
        Use::new("FF", ff, f),
        Use::new(block, dsp, m),
        Use::new("RAMB18 (36 Kb counted as 2)", bram18, b),
    ]
}

/// The resources over 100 %, as `DSP48E1 120/90`.
pub fn overfull(uses: &[Use]) -> Vec<String> {
    uses.iter()
        .filter(|u| u.used > u.available)
        .map(|u| format!("{} {}/{}", u.resource, u.used, u.available))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(name: &str) -> Target {
        Target::from_name(name).expect("a family")
    }

    #[test]
    fn parts_are_found_by_family_and_defaults_are_the_first() {
        assert_eq!(Device::default_of(t("ecp5")).unwrap().name, "LFE5U-85F");
        assert_eq!(
            Device::default_of(t("ice40-hx8k")).unwrap().name,
            "iCE40HX8K"
        );
        assert!(Device::default_of(t("xc7")).is_none());
        assert_eq!(
            Device::find(t("ecp5"), "lfe5u-25f").unwrap().pnr_args[0],
            "--25k"
        );
        let e = Device::find(t("ecp5"), "iCE40HX1K").unwrap_err();
        assert!(
            e.contains("LFE5U-25F") && e.contains("--target ecp5"),
            "{e}"
        );
        assert!(Device::find(t("generic"), "x").is_err());
        // Every part belongs to a family whose placer it names (or none).
        for d in devices() {
            assert_eq!(d.pnr_args.is_empty(), d.capacity.is_some(), "{}", d.name);
        }
    }

    #[test]
    fn utilisation_is_used_over_available() {
        let log = "Info: Device utilisation:\n\
                   Info: \t          TRELLIS_IO:     7/  365     1%\n\
                   Info: \t          DCCA:     0/   56     0%\n\
                   Info: \t        MULT18X18D:    49/  156    31%\n";
        let u = placed(log);
        assert_eq!(u.len(), 2);
        assert_eq!(u[1].resource, "MULT18X18D");
        assert!((u[1].percent - 100.0 * 49.0 / 156.0).abs() < 1e-9);
        assert!(overfull(&u).is_empty());
        let d = Device::find(t("xc7"), "XC7A35T").unwrap();
        let u = from_capacity(&d, 1000, 2000, 120, 4);
        assert_eq!(overfull(&u), ["DSP48E1 120/90"]);
    }
}
