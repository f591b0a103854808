//! The FMU file (FMI 2.0 Co-Simulation for Linux x86-64; docs/fmu.md): modelDescription.xml
//! written from [`pumpcyl::fmu::variables`] through the FMI schema types, the configuration in
//! `resources/`, and the shared library of crates/fmu in `binaries/linux64/`, zipped.

use anyhow::{anyhow, bail, Result};
use fmi_schema::fmi2::{
    BaseUnit, Boolean, Causality as Fmi2Causality, CoSimulation, Fmi2ModelDescription, Fmi2Unit,
    Fmi2VariableDependency, Initial, InitialUnknowns, ModelStructure, ModelVariables, Outputs,
    Real, RealAttributes, ScalarVariable, ScalarVariableElement, SimpleType, SimpleTypeElement,
    TypeDefinitions, UnitDefinitions, Variability,
};
use fmi_schema::traits::FmiModelDescription;
use pumpcyl::fmu::{
    variables, Causality, Config, Controller, ModelKind, Value, Variable, CONFIG_FILE,
    MODEL_IDENTIFIER, UNITS,
};
use std::io::Write;

/// The FMU of `config` as the bytes of its zip archive.
pub fn archive(config: &Config) -> Result<Vec<u8>> {
    let library = pumpcyl_fmu_binary::SHARED_LIBRARY;
    if library.is_empty() {
        bail!("FMU export builds the shared library for Linux x86-64, and this pumpcyl was built for another platform");
    }
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let deflated = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .unix_permissions(0o644);
    let (xml, toml) = (model_description(config)?, config.to_toml());
    let files: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("resources/{CONFIG_FILE}"), toml.as_bytes()),
        (format!("binaries/linux64/{MODEL_IDENTIFIER}.so"), library),
    ];
    for (name, bytes) in files {
        zip.start_file(name, deflated)?;
        zip.write_all(bytes)?;
    }
    Ok(zip.finish()?.into_inner())
}

/// modelDescription.xml of an FMU of `config`.
pub fn model_description(config: &Config) -> Result<String> {
    let vars = variables(config);
    let index = |c: Causality| -> Vec<u32> {
        vars.iter()
            .enumerate()
            .filter(|(_, v)| v.causality == c)
            .map(|(k, _)| k as u32 + 1)
            .collect()
    };
    let unknowns = |ix: Vec<u32>| -> Vec<Fmi2VariableDependency> {
        ix.into_iter()
            .map(|index| Fmi2VariableDependency {
                index,
                ..Default::default()
            })
            .collect()
    };
    let md = Fmi2ModelDescription {
        fmi_version: "2.0".into(),
        model_name: model_name(config).into(),
        guid: config.guid.clone(),
        description: Some(description_of(config)),
        author: Some("pumpcyl".into()),
        version: Some(env!("CARGO_PKG_VERSION").into()),
        generation_tool: Some(format!("pumpcyl {}", env!("CARGO_PKG_VERSION"))),
        variable_naming_convention: Some("flat".into()),
        number_of_event_indicators: Some(0),
        co_simulation: Some(CoSimulation {
            model_identifier: MODEL_IDENTIFIER.into(),
            can_handle_variable_communication_step_size: Some(true),
            can_be_instantiated_only_once_per_process: Some(false),
            can_get_and_set_fmu_state: Some(false),
            can_serialize_fmu_state: Some(false),
            provides_directional_derivative: Some(false),
            ..Default::default()
        }),
        unit_definitions: Some(unit_definitions(&vars)),
        type_definitions: Some(type_definitions(&vars)),
        model_variables: ModelVariables {
            variables: vars.iter().map(scalar_variable).collect(),
        },
        model_structure: ModelStructure {
            outputs: Outputs {
                unknowns: unknowns(index(Causality::Output)),
            },
            initial_unknowns: InitialUnknowns {
                unknowns: unknowns(index(Causality::Output)),
            },
            ..Default::default()
        },
        ..Default::default()
    };
    let xml = md
        .serialize()
        .map_err(|e| anyhow!("modelDescription.xml: {e}"))?;
    // fmi-schema 0.8 writes DefaultExperiment before UnitDefinitions, against the order of
    // fmi2ModelDescription.xsd; it goes in here, after TypeDefinitions
    let experiment = format!(
        "<DefaultExperiment startTime=\"0\" stopTime=\"6\" stepSize=\"{}\"/>",
        1.0 / pumpcyl::emulator::PLC_RATE_HZ
    );
    let xml = xml.replacen(
        "<ModelVariables>",
        &format!("{experiment}<ModelVariables>"),
        1,
    );
    // and it writes an empty <Derivatives/>, which the schema forbids (a Co-Simulation FMU
    // without continuous states exposed has none)
    let mut xml = xml.replacen("<Derivatives/>", "", 1);
    // and its Real has no `unit` attribute: each variable states its unit besides its type's
    // (FMPy and some importers read only the variable's own)
    for u in used_units(&vars) {
        let declared = format!("declaredType=\"{}\"", type_name(u.name));
        xml = xml.replace(&declared, &format!("{declared} unit=\"{}\"", u.name));
    }
    Ok(format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{xml}\n"
    ))
}

fn model_name(c: &Config) -> &'static str {
    match (c.model, c.controller) {
        (ModelKind::Emulator, Controller::Article) => "pumpcyl.EmulatorClosedLoop",
        (ModelKind::Emulator, Controller::External) => "pumpcyl.EmulatorPlant",
        (ModelKind::Linear, Controller::Article) => "pumpcyl.LinearClosedLoop",
        (ModelKind::Linear, Controller::External) => "pumpcyl.LinearPlant",
    }
}

/// What the FMU of `c` holds, in words.
pub fn description_of(c: &Config) -> String {
    let model = match c.model {
        ModelKind::Emulator if c.effects => {
            "the nonlinear rig emulator with every effect of docs/emulator.md"
        }
        ModelKind::Emulator => "the nonlinear rig emulator, its effects off",
        ModelKind::Linear => {
            "the linear model of Goytil, Hansen & Tvilde, Actuators 2025, 14(8), 366, section 2.3"
        }
    };
    let d = c.rig.circuit.description();
    let control = match c.controller {
        Controller::Article => d.controller_words,
        Controller::External => "driven by the motor speed commands",
    };
    let circuit = d.fmu_words;
    format!("pumpcyl {circuit} pump-controlled cylinder: {model}, {control} (docs/fmu.md)")
}

/// What the FMU's emulator uses at the parameters' start values ([`crate::emulated::basis`]);
/// a host that sets `beta_bar` or the mass moves the emulator with it
/// (docs/emulator.md#what-a-user-rig-gets). The linear model's β is its `beta_bar`.
pub fn emulator_basis(c: &Config) -> Result<String> {
    if c.model == ModelKind::Linear {
        return Ok(format!(
            "linear model: beta_bar {} bar, mass {} kg (parameters a host may set)",
            pumpcyl::units::readable(c.rig.beta_bar),
            pumpcyl::units::readable(c.rig.mass_kg)
        ));
    }
    let effects =
        pumpcyl::emulator::Effects::switched(&c.rig, c.effects).map_err(|e| anyhow!(e))?;
    let basis = crate::emulated::basis(&c.rig, &effects).map_err(|e| anyhow!(e))?;
    Ok(format!(
        "{basis}; at the parameters' start values: a host that sets beta_bar or mass_kg moves the emulator with them"
    ))
}

/// The type name carrying a unit: one SimpleType per unit, every Real declared with its unit's.
fn type_name(unit: &str) -> String {
    format!("pumpcyl.{unit}")
}

fn used_units(vars: &[Variable]) -> Vec<&'static pumpcyl::fmu::Unit> {
    let mut names: Vec<&str> = vars.iter().filter_map(|v| v.unit).collect();
    names.sort_unstable();
    names.dedup();
    names
        .into_iter()
        .filter_map(|n| UNITS.iter().find(|u| u.name == n))
        .collect()
}

fn unit_definitions(vars: &[Variable]) -> UnitDefinitions {
    let units = used_units(vars)
        .into_iter()
        .map(|u| {
            let exp = |e: i32| (e != 0).then_some(e);
            Fmi2Unit {
                name: u.name.into(),
                base_unit: Some(BaseUnit {
                    kg: exp(u.base[0]),
                    m: exp(u.base[1]),
                    s: exp(u.base[2]),
                    rad: exp(u.base[3]),
                    a: exp(u.base[4]),
                    factor: (u.factor != 1.0).then_some(u.factor),
                    ..Default::default()
                }),
                display_unit: Vec::new(),
            }
        })
        .collect();
    UnitDefinitions { units }
}

fn type_definitions(vars: &[Variable]) -> TypeDefinitions {
    let types = used_units(vars)
        .into_iter()
        .map(|u| SimpleType {
            name: type_name(u.name),
            description: None,
            elem: SimpleTypeElement::Real(RealAttributes {
                unit: Some(u.name.into()),
                ..Default::default()
            }),
        })
        .collect();
    TypeDefinitions { types }
}

fn scalar_variable(v: &Variable) -> ScalarVariable {
    let (causality, variability, initial) = match v.causality {
        Causality::Parameter => (
            Fmi2Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
        ),
        Causality::Input => (Fmi2Causality::Input, Variability::Continuous, None),
        Causality::Output => (Fmi2Causality::Output, Variability::Continuous, None),
    };
    let elem = match v.start {
        Some(Value::Boolean(b)) => ScalarVariableElement::Boolean(Boolean {
            start: Some(b),
            ..Default::default()
        }),
        start => ScalarVariableElement::Real(Real {
            declared_type: v.unit.map(type_name),
            start: match start {
                Some(Value::Real(x)) => Some(x),
                _ => None,
            },
            ..Default::default()
        }),
    };
    ScalarVariable {
        name: v.name.clone(),
        value_reference: v.value_reference,
        description: Some(v.description.clone()),
        causality,
        variability: Some(variability),
        initial,
        elem,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::rig::Rig;

    #[test]
    fn the_model_description_reads_back_with_every_variable_and_unit() {
        let c = Config::new(
            ModelKind::Emulator,
            Controller::Article,
            true,
            Rig::default(),
        );
        let xml = model_description(&c).unwrap();
        let md = Fmi2ModelDescription::deserialize(xml.trim_start_matches(|ch| ch != '\n').trim())
            .unwrap();
        assert_eq!(md.guid, c.guid);
        assert_eq!(md.model_variables.variables.len(), variables(&c).len());
        let v = md.model_variable_by_name("beta_bar").unwrap();
        assert!(
            matches!(&v.elem, ScalarVariableElement::Real(r) if r.declared_type.as_deref() == Some("pumpcyl.bar") && r.start == Some(165.0))
        );
        assert!(
            xml.contains(
                r#"<Unit name="bar"><BaseUnit kg="1" m="-1" s="-2" factor="100000"/></Unit>"#
            ),
            "{xml}"
        );
    }
}
