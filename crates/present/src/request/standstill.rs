//! The requests of the article's standstill and drive identification (§2.4): `leakage` (the
//! chamber leakages from a standstill point) and `identify-drive` (a drive's velocity-loop gain
//! from a speed step).

use super::{check_field, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::figures::Chart;
use crate::identification::{drive_csv, drive_json, drive_text, leakage_text};
use pumpcyl::ident::{
    identify_drive, standstill_warnings, DriveFit, DriveRecord, Leakage, Standstill,
};
use pumpcyl::record::Record;
use serde_json::Value;

/// Where the standstill point comes from.
#[derive(Debug, Clone)]
pub enum Point {
    /// A standstill record, averaged.
    Record(Box<Record>),
    /// The point given.
    Given(Standstill),
}

/// `leakage`: c1 and c2 from a standstill point for a given c12 (the article §2.4).
#[derive(Debug, Clone)]
pub struct LeakageRequest {
    /// The rig.
    pub rig: RigInput,
    /// The standstill point.
    pub point: Point,
    /// The cross-port leakage c12 (m⁵/(N·s)), ≥ 0.
    pub c12: f64,
}

/// The leakages at a standstill point.
pub struct LeakageOutcome {
    standstill: Standstill,
    leakage: Leakage,
    warnings: Vec<String>,
}

impl Request for LeakageRequest {
    type Outcome = LeakageOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<LeakageOutcome> {
        let ok = self.c12.is_finite() && self.c12 >= 0.0;
        check_field("c12", self.c12, ok, "must be >= 0")?;
        let (standstill, warnings) = match &self.point {
            Point::Record(rec) => (Standstill::of_record(rec)?, standstill_warnings(rec)),
            Point::Given(s) => (*s, Vec::new()),
        };
        let leakage = standstill.leakage(&self.rig.rig, self.c12)?;
        Ok(LeakageOutcome {
            standstill,
            leakage,
            warnings,
        })
    }
}

impl Document for LeakageOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(serde_json::to_value(self.leakage)?)
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(leakage_text(&self.standstill, &self.leakage))
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// `identify-drive`: a drive's velocity-loop gain Km from a motor speed step (the article
/// §2.4.1), the rotor inertia and current-loop bandwidth the rig's.
#[derive(Debug, Clone)]
pub struct DriveRequest {
    /// The rig.
    pub rig: RigInput,
    /// The speed-step record.
    pub record: DriveRecord,
    /// Which motor (1 or 2).
    pub motor: u8,
}

/// A drive's fitted gain.
pub struct DriveOutcome {
    request: DriveRequest,
    fit: DriveFit,
    inertia_kg_m2: f64,
}

impl Request for DriveRequest {
    type Outcome = DriveOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<DriveOutcome> {
        let rig = &self.rig.rig;
        let inertia_kg_mm2 = match self.motor {
            1 => rig.motor_inertia_1_kg_mm2,
            2 => rig.motor_inertia_2_kg_mm2,
            m => {
                let given = Given::Number(f64::from(m));
                return Err(FieldError::new("motor", given, "must be 1 or 2").into());
            }
        };
        let inertia_kg_m2 = inertia_kg_mm2 * 1e-6;
        let bandwidth = rig.current_loop_bandwidth_rad_per_s;
        let fit = identify_drive(&self.record, inertia_kg_m2, bandwidth)?;
        Ok(DriveOutcome {
            request: self.clone(),
            fit,
            inertia_kg_m2,
        })
    }
}

impl DriveOutcome {
    /// The record beside the fitted model as CSV.
    pub fn csv(&self) -> String {
        drive_csv(&self.request.record, &self.fit)
    }

    /// The record beside the fitted model as a figure.
    pub fn chart(&self) -> Chart {
        Chart::drive_step(&self.request.record, &self.fit)
    }
}

impl Document for DriveOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let r = &self.request;
        Ok(drive_json(
            &r.record,
            r.motor,
            &self.fit,
            self.inertia_kg_m2,
        ))
    }

    fn text(&self) -> anyhow::Result<String> {
        let r = &self.request;
        let bandwidth = r.rig.rig.current_loop_bandwidth_rad_per_s;
        Ok(drive_text(
            &r.record,
            r.motor,
            &self.fit,
            self.inertia_kg_m2,
            bandwidth,
        ))
    }
}
