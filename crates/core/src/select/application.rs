//! The application a selection is made for (docs/formats.md#application-toml): the rig, the
//! uncertainty of the undissolved air, the targets, the loads, the waves, the circuits and the
//! pressure levels to try, read from TOML and checked.

use super::*;

/// An application to choose a circuit for (docs/formats.md#application-toml): the rig, the
/// uncertainty of the undissolved air, the targets, the loads, the waves and the pressure
/// levels to try. Field names are the TOML keys; units are in the names.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Application {
    /// The reference gas fraction X (dimensionless).
    pub gas_fraction: f64,
    /// The lowest gas fraction considered.
    pub gas_fraction_min: f64,
    /// The highest gas fraction considered.
    pub gas_fraction_max: f64,
    /// Pure-oil bulk modulus of the gas-fraction model (bar).
    pub beta_oil_bar: f64,
    /// Phase margin target (deg).
    pub target_pm_deg: f64,
    /// Gain margin target (dB).
    pub target_gm_db: f64,
    /// Stroke excursion on each side of x0 (mm).
    pub stroke_mm: f64,
    /// Loads, each its mass at x0 (kg); empty = the rig's `mass_kg`.
    pub mass_kg: Vec<f64>,
    /// External force range [lowest, highest] (N).
    pub external_force_n: [f64; 2],
    /// Mean chamber pressures of the low-pressure circuit to try (bar).
    pub low_pressure_bar: Vec<f64>,
    /// Mean chamber pressures of the pressurised circuit to try (bar).
    pub pressurised_bar: Vec<f64>,
    /// Accumulator pre-charges of the one-motor circuits (dual pump, single pump) to try (bar).
    pub precharge_bar: Vec<f64>,
    /// Supply pressures of the valve-controlled cylinder to try (bar).
    pub supply_bar: Vec<f64>,
    /// The circuits to try (`dpm`, `dual-pump`, `single-pump`); absent: every circuit the
    /// rig's components allow ([`circuits::allowed_circuits`]).
    pub circuits: Vec<CircuitKind>,
    /// The waves to track within an error.
    pub wave: Vec<WaveRequirement>,
    /// Largest 10–90 % rise time of a 5 mm step allowed (s); absent: not required.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rise_time_s: Option<f64>,
    /// The rig: a `[rig]` table (any rig key; absent keys take the article's rig) or the name
    /// of a rig file, relative to the application file (docs/formats.md#application-toml).
    #[serde(deserialize_with = "rig_table_or_file")]
    pub rig: Rig,
    /// Where the rig came from (not a key).
    #[serde(skip)]
    pub rig_from: RigFrom,
    /// Where the gas-fraction range came from (not a key).
    #[serde(skip)]
    pub gas_fraction_from: GasFractionFrom,
    /// The keys the application leaves to the rig (not a key): each follows it as
    /// [`Application::with_rig`] says.
    #[serde(skip)]
    pub follows_rig: FollowsRig,
}

/// The application keys that, absent, follow the rig (docs/select.md#the-gas-fraction): the
/// gas fraction is read off the rig's β at its mean chamber pressure (the article's
/// identification on the article's rig), its range is a factor 2 either way of it, and the
/// loads are the rig's `mass_kg` (the article's two loads on the article's rig) and its
/// `external_force_n` (a range of that one force).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FollowsRig {
    /// `gas_fraction` follows the rig.
    pub gas_fraction: bool,
    /// `gas_fraction_min` is half the reference.
    pub gas_fraction_min: bool,
    /// `gas_fraction_max` is twice the reference.
    pub gas_fraction_max: bool,
    /// `mass_kg` follows the rig.
    pub mass_kg: bool,
    /// `external_force_n` is the rig's force, [F, F].
    pub external_force_n: bool,
    /// `circuits` are those the rig's components allow.
    pub circuits: bool,
}

impl FollowsRig {
    /// Every such key follows the rig.
    pub const ALL: FollowsRig = FollowsRig {
        gas_fraction: true,
        gas_fraction_min: true,
        gas_fraction_max: true,
        mass_kg: true,
        external_force_n: true,
        circuits: true,
    };

    /// Those of `self` whose key is not `key` (a key stated).
    fn stated(mut self, key: &str) -> FollowsRig {
        match key {
            "gas_fraction" => self.gas_fraction = false,
            "gas_fraction_min" => self.gas_fraction_min = false,
            "gas_fraction_max" => self.gas_fraction_max = false,
            "mass_kg" => self.mass_kg = false,
            "external_force_n" => self.external_force_n = false,
            "circuits" => self.circuits = false,
            _ => {}
        }
        self
    }
}

impl Default for FollowsRig {
    fn default() -> Self {
        FollowsRig::ALL
    }
}

/// The article's two loads (kg at x0), the loads of the article's application on its rig.
pub const ARTICLE_LOADS_KG: [f64; 2] = [4898.0, 10593.0];

/// The `rig` key: a table of rig keys, or a file name (the placeholder rig it gives here is
/// replaced by the file's as the application is read: [`Application::from_file_in`]).
fn rig_table_or_file<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Rig, D::Error> {
    struct TableOrFile;
    impl<'de> serde::de::Visitor<'de> for TableOrFile {
        type Value = Rig;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a [rig] table or the name of a rig file")
        }
        fn visit_str<E: serde::de::Error>(self, _: &str) -> Result<Rig, E> {
            Ok(Rig::default())
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Rig, A::Error> {
            serde::Deserialize::deserialize(serde::de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_any(TableOrFile)
}

/// An identification's word on the gas fraction: the interval of β its records leave, at the
/// pressure they were taken (docs/select.md#from-an-identification).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BetaEvidence {
    /// The β interval (bar).
    pub beta_bar: [f64; 2],
    /// The point estimate (bar).
    pub beta_nominal_bar: f64,
    /// The records' mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// The interval's confidence level.
    pub confidence: f64,
}

impl BetaEvidence {
    /// Identify `exp`'s records and read the β interval at `confidence` off the profiles
    /// (docs/identification.md, "Uncertainty"), at the first record's mean chamber pressure.
    ///
    /// # Errors
    /// The identification or the profiles fail, or the first record has no chamber pressures.
    pub fn of_records(
        exp: &crate::ident::Experiment,
        confidence: f64,
    ) -> Result<BetaEvidence, SelectError> {
        let p_mean_bar = exp.mean_chamber_pressure_bar().ok_or_else(|| {
            SelectError::Input(format!(
                "{}: the first dataset's record has no chamber pressures (p1_bar, p2_bar) to read the gas fraction at",
                exp.path.display()
            ))
        })?;
        let (_, region) = crate::design::Region::of_records(exp, confidence)?;
        Ok(BetaEvidence::of_region(&region, confidence, p_mean_bar))
    }

    /// The β interval of a confidence `region` already computed (at `confidence`), read at the
    /// records' mean chamber pressure `p_mean_bar` (bar).
    pub fn of_region(region: &crate::design::Region, confidence: f64, p_mean_bar: f64) -> Self {
        BetaEvidence {
            beta_bar: region.beta_bar,
            beta_nominal_bar: region.nominal.beta_bar,
            p_mean_bar,
            confidence,
        }
    }
}

impl Default for Application {
    /// The article's application with pumpcyl's requirement (docs/select.md#the-article-s-application):
    /// the article's rig, its gas fraction 2.64 % (β 165 bar at 4.4 bar) and its two loads; a
    /// factor 2 either way on the gas fraction, the default targets ([`Targets::default`]: PM 34°,
    /// GM 6 dB over x0 ± 50 mm) and the 0.2 Hz ±35 mm wave within 14 mm are pumpcyl's choices,
    /// since the article sets no range, no gain-margin target and no tracking requirement.
    ///
    /// [`Targets::default`]: crate::design::Targets
    fn default() -> Self {
        let x = ARTICLE_READING
            .gas_fraction(crate::bulk::BETA_OIL_BAR)
            .unwrap_or(0.0264);
        Application {
            gas_fraction: x,
            gas_fraction_min: x / 2.0,
            gas_fraction_max: 2.0 * x,
            beta_oil_bar: crate::bulk::BETA_OIL_BAR,
            target_pm_deg: 34.0,
            target_gm_db: 6.0,
            stroke_mm: 50.0,
            mass_kg: ARTICLE_LOADS_KG.to_vec(),
            external_force_n: [0.0, 0.0],
            low_pressure_bar: (1..=10).map(f64::from).collect(),
            pressurised_bar: vec![20.0, 30.0, 50.0],
            precharge_bar: (1..=10).map(f64::from).collect(),
            supply_bar: vec![35.0, 70.0, 100.0, 140.0, 210.0],
            circuits: circuits::allowed_circuits(&Rig::default()),
            wave: vec![WaveRequirement {
                freq_hz: 0.2,
                amp_mm: 35.0,
                max_error_mm: 14.0,
            }],
            max_rise_time_s: None,
            rig: Rig::default(),
            rig_from: RigFrom::Article,
            gas_fraction_from: GasFractionFrom::Article(ARTICLE_READING),
            follows_rig: FollowsRig::ALL,
        }
    }
}

impl Application {
    /// Parse an application from TOML text; `name` stands for the file in messages, which name
    /// the line and the key. A `rig` file name is read from `files`, relative to `dir`.
    pub fn from_toml_in(
        files: &dyn crate::source_files::Files,
        text: &str,
        name: &str,
        dir: &std::path::Path,
    ) -> Result<Application, SelectError> {
        let located = |key: &str, message: String| {
            let path: Vec<crate::source_files::Key> =
                key.split('.').map(crate::source_files::Key::Name).collect();
            let line = crate::source_files::toml_line(text, &path)
                .map_or(String::new(), |l| format!("line {l}, "));
            SelectError::Input(format!("{name}: {line}key `{key}`: {message}"))
        };
        let syntax = |e: toml::de::Error| {
            SelectError::Input(format!(
                "{name}: {}",
                crate::source_files::toml_error(&e, text)
            ))
        };
        let mut app: Application = toml::from_str(text).map_err(syntax)?;
        let raw: toml::Table = toml::from_str(text).map_err(syntax)?;
        app.rig_from = match raw.get("rig") {
            Some(toml::Value::String(file)) => {
                let path = dir.join(file);
                app.rig =
                    Rig::from_file_in(files, &path).map_err(|e| located("rig", e.to_string()))?;
                RigFrom::File {
                    path: path.display().to_string(),
                }
            }
            Some(_) => RigFrom::Table,
            None => RigFrom::Article,
        };
        app.follows_rig = raw.keys().fold(FollowsRig::ALL, |f, key| f.stated(key));
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, message)| located(&key, message))?;
        Ok(app)
    }

    /// [`Application::from_toml_in`] with a `rig` file name read from disk, relative to the
    /// working directory.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Application, SelectError> {
        Self::from_toml_in(
            &crate::source_files::Disk,
            text,
            name,
            std::path::Path::new("."),
        )
    }

    /// Read and check an application file; a `rig` file name is relative to it.
    pub fn from_file_in(
        files: &dyn crate::source_files::Files,
        path: &std::path::Path,
    ) -> Result<Application, SelectError> {
        let name = path.display().to_string();
        let text = crate::source_files::read_text(files, path)
            .map_err(|e| SelectError::Input(format!("{name}: {e}")))?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        Self::from_toml_in(files, &text, &name, dir)
    }

    /// The application on `rig` (from `from`): the keys it leaves to the rig follow it
    /// ([`FollowsRig`]), then every value is checked.
    ///
    /// # Errors
    /// The rig's β at its mean pressure gives no gas fraction, or a value does not fit the
    /// rig (a wave beyond its stroke, a load out of range), the key named.
    pub fn with_rig(&self, rig: Rig, from: RigFrom) -> Result<Application, SelectError> {
        let mut app = Application {
            rig,
            rig_from: from,
            ..self.clone()
        };
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, m)| SelectError::Input(format!("key `{key}`: {m}")))?;
        Ok(app)
    }

    /// Set the keys that follow the rig ([`FollowsRig`]) from it: the gas fraction from the
    /// rig's β at its mean chamber pressure ([`BetaReading::for_rig`]), a factor 2 either way,
    /// and the loads; the error names the key.
    fn resolve(&mut self) -> Result<(), (String, String)> {
        // what the keys follow, checked first so that a fault is named where it lies
        self.check_rig()?;
        check_oil(self.beta_oil_bar)?;
        let article_rig = self.rig_from == RigFrom::Article;
        let follows = self.follows_rig;
        if follows.circuits {
            self.circuits = circuits::allowed_circuits(&self.rig);
        }
        if follows.mass_kg {
            self.mass_kg = if article_rig && self.rig.mass_kg == Rig::default().mass_kg {
                ARTICLE_LOADS_KG.to_vec()
            } else {
                Vec::new()
            };
        }
        if follows.external_force_n {
            self.external_force_n = [self.rig.external_force_n; 2];
        }
        if follows.gas_fraction {
            let reading = BetaReading::for_rig(&self.rig, article_rig);
            let model = self.rig.bulk_model();
            self.gas_fraction = reading.gas_fraction_under(model, self.beta_oil_bar).map_err(|e| {
                let m = format!(
                    "absent, so read off the rig's beta {} bar at its mean chamber pressure {} bar, which gives none: {e}; state gas_fraction",
                    reading.beta_bar, reading.p_mean_bar
                );
                ("gas_fraction".to_string(), m)
            })?;
            self.gas_fraction_from = if reading == ARTICLE_READING {
                GasFractionFrom::Article(reading)
            } else {
                GasFractionFrom::Rig(reading)
            };
        } else if matches!(
            self.gas_fraction_from,
            GasFractionFrom::Article(_) | GasFractionFrom::Rig(_)
        ) {
            self.gas_fraction_from = GasFractionFrom::Application;
        }
        if follows.gas_fraction_min {
            self.gas_fraction_min = 0.5 * self.gas_fraction;
        }
        if follows.gas_fraction_max {
            self.gas_fraction_max = 2.0 * self.gas_fraction;
        }
        Ok(())
    }

    /// Apply `KEY=VALUE` overrides (`rig.KEY=VALUE` for a rig key; values in TOML), then check;
    /// errors name `source_name` and the key.
    pub fn with_overrides(
        &self,
        source_name: &str,
        assignments: &[String],
    ) -> Result<Application, SelectError> {
        if assignments.is_empty() {
            return Ok(self.clone());
        }
        let err = |a: &str, message: String| SelectError::Set {
            source_name: source_name.to_string(),
            assignment: a.to_string(),
            message,
        };
        let mut table = toml::Table::try_from(self).map_err(|e| err("", e.to_string()))?;
        for a in assignments {
            let (key, raw) = a
                .split_once('=')
                .ok_or_else(|| err(a, "expected KEY=VALUE".into()))?;
            let (key, raw) = (key.trim(), raw.trim());
            let value = crate::source_files::parse_value(raw);
            let (place, leaf) = match key.strip_prefix("rig.") {
                Some(rig_key) => (
                    table.get_mut("rig").and_then(toml::Value::as_table_mut),
                    rig_key,
                ),
                None => (Some(&mut table), key),
            };
            let place = place.ok_or_else(|| err(a, "no rig table".into()))?;
            let value = match place.get(leaf) {
                Some(current) => {
                    crate::source_files::typed_like(current, value).map_err(|got| {
                        err(
                            a,
                            format!("key `{key}` takes a {}, got {got}", current.type_str()),
                        )
                    })?
                }
                // an optional key left out: its type is checked as the application is read
                None if OPTIONAL_KEYS.contains(&key) => value,
                // a rig key its table leaves out (an optional one, a circuit's): checked as
                // the rig is read
                None if key.starts_with("rig.") && Rig::key_docs().any(|(k, _)| k == leaf) => value,
                None => return Err(err(a, format!("unknown key `{key}`"))),
            };
            place.insert(leaf.to_string(), value);
        }
        let app: Application = table.try_into().map_err(|e: toml::de::Error| {
            err(
                &assignments.join(" "),
                crate::source_files::serde_message(e.message()),
            )
        })?;
        let mut app = Application {
            rig_from: self.rig_from.clone(),
            gas_fraction_from: self.gas_fraction_from,
            follows_rig: assignments
                .iter()
                .filter_map(|a| a.split_once('=').map(|(k, _)| k.trim()))
                .fold(self.follows_rig, FollowsRig::stated),
            ..app
        };
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, message)| SelectError::Invalid {
                source_name: source_name.to_string(),
                key: key.to_string(),
                message,
            })?;
        Ok(app)
    }

    /// The application with its gas-fraction range read off an identified interval of β
    /// (docs/select.md#from-an-identification): the soft end of β gives the highest X, the
    /// stiff end the lowest, the estimate the reference.
    ///
    /// # Errors
    /// An interval that is not ordered around the estimate, or a β the gas-fraction model
    /// cannot reach (at or above the oil's modulus).
    pub fn with_evidence(&self, e: &BetaEvidence) -> Result<Application, SelectError> {
        let [lo, hi] = e.beta_bar;
        if !(lo <= e.beta_nominal_bar && e.beta_nominal_bar <= hi) {
            return Err(SelectError::Input(format!(
                "the beta interval [{lo}, {hi}] bar does not hold its estimate {} bar",
                e.beta_nominal_bar
            )));
        }
        let model = self.rig.bulk_model();
        let x = |b: f64| {
            (model.fit(b, e.p_mean_bar, self.beta_oil_bar))
                .map_err(|err| SelectError::Input(format!("gas fraction from beta {b} bar: {err}")))
        };
        let out = Application {
            gas_fraction_min: x(hi)?,
            gas_fraction: x(e.beta_nominal_bar)?,
            gas_fraction_max: x(lo)?,
            gas_fraction_from: GasFractionFrom::Identification(*e),
            follows_rig: FollowsRig {
                gas_fraction: false,
                gas_fraction_min: false,
                gas_fraction_max: false,
                ..self.follows_rig
            },
            ..self.clone()
        };
        out.validate()
            .map_err(|(key, m)| SelectError::Input(format!("key `{key}`: {m}")))?;
        Ok(out)
    }

    /// The application as TOML with a comment per key, ready to edit (what `pumpcyl select
    /// --print-default` prints).
    pub fn to_commented_toml(&self) -> String {
        let mut table = toml::Table::try_from(self).expect("an application always serialises");
        table.remove("rig");
        let mut out = String::from(
            "# pumpcyl application (docs/formats.md#application-toml; docs/select.md). Units are part of every key.\n\
             # Absent keys take the article's application; the gas fraction and the loads follow the rig.\n\
             # [rig] takes any rig key (`pumpcyl rig`); or name a rig file: rig = \"my-rig.toml\" (relative to this file).\n",
        );
        for (key, doc) in APPLICATION_KEY_DOCS.iter().filter(|(k, _)| *k != "wave") {
            match table.get(*key) {
                Some(value) => out.push_str(&format!("{key} = {value}  # {doc}\n")),
                None => out.push_str(&format!("# {key} = 0.5  # {doc}\n")),
            }
        }
        for w in &self.wave {
            out.push_str(&format!(
                "\n[[wave]]  # a wave to track and the largest control error allowed\nfreq_hz = {:?}\namp_mm = {:?}\nmax_error_mm = {:?}\n",
                w.freq_hz, w.amp_mm, w.max_error_mm
            ));
        }
        out.push_str(&format!(
            "\n[rig]  # {}: the keys that differ from the article's rig (`pumpcyl rig` lists them all)\n",
            self.rig_from.describe()
        ));
        let ours = toml::Table::try_from(&self.rig).expect("a rig always serialises");
        let article = toml::Table::try_from(Rig::file_default()).expect("a rig always serialises");
        for (key, value) in ours.iter().filter(|(k, v)| article.get(*k) != Some(*v)) {
            out.push_str(&format!("{key} = {value}\n"));
        }
        out
    }

    /// Every value checked, the error naming its key: the rig's rules, the loads in the range
    /// of the rig's `mass_kg`, forces finite, at least one wave and one pressure level, the
    /// targets, and what every selection checks (gas fractions, waves, levels).
    pub fn validate(&self) -> Result<(), (String, String)> {
        self.check_rig()?;
        let fail = |key: &str, message: String| Err((key.to_string(), message));
        for &m in &self.mass_kg {
            if let Some(rule) = Rig::check_key("mass_kg", m) {
                return fail("mass_kg", format!("{m}: every load {rule}"));
            }
        }
        for f in self.external_force_n {
            if !(f.is_finite() && f.abs() <= 1e8) {
                return fail(
                    "external_force_n",
                    format!("{f}: must be finite, at most 1e8 N"),
                );
            }
        }
        if self.wave.is_empty() && self.max_rise_time_s.is_none() {
            return fail(
                "wave",
                "no requirement: give at least one [[wave]] or max_rise_time_s".into(),
            );
        }
        if let Some(why) = (self.circuits.iter()).find_map(|k| circuits::not_allowed(&self.rig, *k))
        {
            return fail("circuits", why);
        }
        // the keys that list the levels of the circuits asked for (precharge_bar for the
        // one-motor circuits), named in the error
        let keys = self.levels_keys();
        if keys.is_empty() {
            let names: Vec<&str> = self.circuits.iter().map(|k| k.name()).collect();
            return fail(
                "circuits",
                format!(
                    "{}: select has no pressure level to try on it yet (docs/select.md#circuits)",
                    names.join(", ")
                ),
            );
        }
        if self.levels().is_empty() {
            return fail(&keys, "no pressure level to try".into());
        }
        if self.levels().len() > MAX_LEVELS {
            return fail(&keys, format!("more than {MAX_LEVELS} pressure levels"));
        }
        let targets = [
            ("target_pm_deg", self.target_pm_deg),
            ("target_gm_db", self.target_gm_db),
            ("stroke_mm", self.stroke_mm),
        ];
        for (key, v) in targets {
            if !(v.is_finite() && v >= 0.0) {
                return fail(key, format!("{v}: must be a finite number >= 0"));
            }
        }
        check(&self.rig, &self.requirement(), &self.levels(), None)
    }

    /// The rig's rules, the error naming its key as `rig.KEY`.
    fn check_rig(&self) -> Result<(), (String, String)> {
        self.rig.validate("rig").map_err(|e| match e {
            RigError::Invalid {
                key, value, rule, ..
            } => (format!("rig.{key}"), format!("{value}: {rule}")),
            other => ("rig".to_string(), other.to_string()),
        })
    }

    /// The requirement this application states.
    pub fn requirement(&self) -> Requirement {
        Requirement {
            gas_fraction: self.gas_fraction,
            gas_fraction_min: self.gas_fraction_min,
            gas_fraction_max: self.gas_fraction_max,
            beta_oil_bar: self.beta_oil_bar,
            targets: Targets {
                pm_deg: self.target_pm_deg,
                gm_db: self.target_gm_db,
                stroke_mm: self.stroke_mm,
                mass_kg: self.mass_kg.clone(),
                // no pressure list or waves: each candidate sets β_e and tracks itself
                ..Targets::default()
            },
            waves: self.wave.clone(),
            max_rise_time_s: self.max_rise_time_s,
            external_force_n: self.external_force_n,
            gas_fraction_from: self.gas_fraction_from,
            rig_from: self.rig_from.clone(),
        }
    }

    /// The circuits and pressure levels to try, low-pressure first, pressure rising.
    pub fn levels(&self) -> Vec<(Circuit, f64)> {
        self.circuits_asked()
            .flat_map(|circuit| {
                let mut ps = match circuit.level {
                    PressureLevel::LowPressure => self.low_pressure_bar.clone(),
                    PressureLevel::Pressurised => self.pressurised_bar.clone(),
                    PressureLevel::Precharge => self.precharge_bar.clone(),
                    PressureLevel::Supply => self.supply_bar.clone(),
                };
                ps.sort_by(f64::total_cmp);
                ps.into_iter().map(move |p| (circuit, p))
            })
            .collect()
    }

    /// The candidate circuits of the circuits asked for, in [`Circuit::all`]'s order.
    fn circuits_asked(&self) -> impl Iterator<Item = Circuit> + '_ {
        Circuit::all()
            .into_iter()
            .filter(|c| self.circuits.contains(&c.kind))
    }

    /// The keys that list the pressure levels of the circuits asked for, joined by " / " (each
    /// once, in [`Circuit::all`]'s order).
    fn levels_keys(&self) -> String {
        let mut keys: Vec<&str> = Vec::new();
        for k in self.circuits_asked().map(Circuit::levels_key) {
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        keys.join(" / ")
    }

    /// The application with the circuits to try set to `kinds` (stated: the rig no longer sets
    /// them), checked.
    ///
    /// # Errors
    /// A circuit the rig's components do not allow.
    pub fn with_circuits(&self, kinds: &[CircuitKind]) -> Result<Application, SelectError> {
        let out = Application {
            circuits: kinds.to_vec(),
            follows_rig: FollowsRig {
                circuits: false,
                ..self.follows_rig
            },
            ..self.clone()
        };
        out.validate()
            .map_err(|(key, m)| SelectError::Input(format!("key `{key}`: {m}")))?;
        Ok(out)
    }

    /// Run the selection ([`select`]); `kp` fixes the gain.
    pub fn select(&self, kp: Option<f64>) -> Result<Selection, SelectError> {
        self.select_with(kp, &crate::limits::Work::QUIET)
    }

    /// Run the selection ([`select_with`]) as `work` allows and follows it.
    pub fn select_with(
        &self,
        kp: Option<f64>,
        work: &crate::limits::Work,
    ) -> Result<Selection, SelectError> {
        select_with(&self.rig, &self.requirement(), &self.levels(), kp, work)
    }

    /// Run the selection ([`select_checked`]) with the single-pump candidates' mode check
    /// `mode_check`, as `work` allows and follows it.
    pub fn select_checked(
        &self,
        kp: Option<f64>,
        work: &crate::limits::Work,
        mode_check: &dyn ModeCheck,
    ) -> Result<Selection, SelectError> {
        let (req, levels) = (self.requirement(), self.levels());
        select_checked(&self.rig, &req, &levels, kp, work, mode_check)
    }

    /// The load × level cases its selection evaluates ([`cases`]).
    pub fn cases(&self) -> f64 {
        cases(&self.requirement(), &self.levels())
    }
}

/// Each application key with its unit and meaning, in the order `to_commented_toml` writes them.
pub const APPLICATION_KEY_DOCS: &[(&str, &str)] = &[
    (
        "gas_fraction",
        "reference undissolved-gas fraction X (absent: the rig's beta at its anchor, the mean chamber pressure of its loop at rest, docs/bulk-modulus.md#the-anchor; on the article's rig its 165 bar at 4.4 bar)",
    ),
    (
        "gas_fraction_min",
        "lowest X considered (absent: a factor 2 below; undissolved air varies between applications)",
    ),
    (
        "gas_fraction_max",
        "highest X considered (absent: a factor 2 above; the worst case for beta_e)",
    ),
    (
        "beta_oil_bar",
        "bar, pure-oil bulk modulus of the gas-fraction model",
    ),
    ("target_pm_deg", "deg, phase margin target"),
    ("target_gm_db", "dB, gain margin target"),
    (
        "stroke_mm",
        "mm, stroke excursion checked on each side of x0",
    ),
    (
        "mass_kg",
        "kg, loads (each its mass at x0; along the stroke it follows rig.mass_by_position; empty: rig.mass_kg; absent: the rig's, the article's two loads on its rig)",
    ),
    (
        "external_force_n",
        "N, external force range [lowest, highest] (the standing cost is taken at both; absent: the rig's external_force_n at both ends)",
    ),
    (
        "low_pressure_bar",
        "bar, mean chamber pressures of the low-pressure circuit (accumulator pre-charge)",
    ),
    (
        "pressurised_bar",
        "bar, mean chamber pressures of the pressurised dual-prime-mover circuit",
    ),
    (
        "precharge_bar",
        "bar, accumulator pre-charges of the one-motor circuits (dual-pump, single-pump)",
    ),
    (
        "supply_bar",
        "bar, supply pressures of the valve-controlled cylinder (valve; its beta_e read at the mean chamber pressure its valve holds at rest from each)",
    ),
    (
        "circuits",
        "circuits to try: \"dpm\", \"dual-pump\", \"single-pump\", \"valve\" (absent: every circuit the rig's components allow; docs/select.md#circuits)",
    ),
    (
        "max_rise_time_s",
        "s, largest 10-90 % rise time of a 5 mm step (absent: not required)",
    ),
    (
        "wave",
        "waves to track: [[wave]] freq_hz, amp_mm, max_error_mm",
    ),
];

/// The application keys that may be absent (no value to take a type from).
const OPTIONAL_KEYS: &[&str] = &["max_rise_time_s"];

/// Most pressure levels an application may list.
pub const MAX_LEVELS: usize = 200;
