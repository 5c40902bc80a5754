//! The elements of `modelDescription.xml` outside `<ModelVariables>`: the root (which
//! picks the standard), `<CoSimulation>` and `<ModelExchange>` (their `modelIdentifier` a
//! plain file name: it names the library to load), `<DefaultExperiment>`, and the
//! continuous states resolved from `<ModelStructure>`'s derivatives.

use super::text::{attr, cut, line_column, plain_file_name, Attrs};
use super::{
    fmi2, fmi3, CoSimulation, ContinuousState, DefaultExperiment, Doc, Element, ModelExchange,
    ScheduledExecution, Standard,
};
use crate::ImportError;

impl Doc<'_> {
    /// The continuous states of `<ModelExchange>`, from `<ModelStructure>`'s derivatives
    /// and each derivative's `derivative` attribute.
    pub(super) fn resolve_states(&mut self) -> Result<(), ImportError> {
        let Some(me) = self.md.model_exchange.as_mut() else { return Ok(()) };
        me.number_of_event_indicators = self.event_indicators;
        let fmi3 = self.md.fmi_version.starts_with("3.");
        let variables = &self.md.variables;
        // FMI 2.0 refers to variables by 1-based index, FMI 3.0 by value reference.
        let vr_of = |key: u32| -> Option<u32> {
            if fmi3 {
                Some(key)
            } else {
                variables.get((key as usize).checked_sub(1)?).map(|v| v.vr)
            }
        };
        let (what, key) = if fmi3 {
            ("<ContinuousStateDerivative valueReference", "value reference")
        } else {
            ("<Derivatives><Unknown index", "index")
        };
        let mut states = Vec::with_capacity(self.structure_derivatives.len());
        for &(d, pos) in &self.structure_derivatives {
            let bad = |why: String| {
                let (line, column) = line_column(self.text, pos);
                ImportError::Description {
                    line,
                    column,
                    message: format!("{what}=\"{d}\">: {why}"),
                }
            };
            let derivative = vr_of(d).ok_or_else(|| bad(format!("no variable has {key} {d}")))?;
            let of = self
                .derivative_of
                .get(&d)
                .copied()
                .ok_or_else(|| bad("the variable has no `derivative` attribute".into()))?;
            let state =
                vr_of(of).ok_or_else(|| bad(format!("its state ({key} {of}) is no variable")))?;
            states.push(ContinuousState { state, derivative });
        }
        me.states = states;
        Ok(())
    }

    /// `<fmiModelDescription>`: picks the standard by `fmiVersion`.
    pub(super) fn root(
        &mut self,
        name: &str,
        a: &Attrs,
        pos: usize,
    ) -> Result<Box<dyn Standard>, ImportError> {
        if self.seen_root {
            return Err(self.error(pos, format!("a second root element <{name}>")));
        }
        if name != "fmiModelDescription" {
            return Err(self.error(
                pos,
                format!("the root element is <{name}>, expected <fmiModelDescription>"),
            ));
        }
        self.seen_root = true;
        let version = self.required(a, name, "fmiVersion", pos)?.trim().to_owned();
        // What the two standards spell differently outside the variables: the token
        // attribute and the state capability flags.
        let (standard, token, flags): (Box<dyn Standard>, _, _) = if version.starts_with("2.") {
            (
                Box::new(fmi2::Fmi2::default()),
                "guid",
                ("canGetAndSetFMUstate", "canSerializeFMUstate"),
            )
        } else if version.starts_with("3.") {
            (
                Box::new(fmi3::Fmi3::default()),
                "instantiationToken",
                ("canGetAndSetFMUState", "canSerializeFMUState"),
            )
        } else {
            return Err(ImportError::UnsupportedVersion(cut(&version, 40)));
        };
        self.state_flags = flags;
        if version.starts_with("2.") {
            self.event_indicators = self
                .number::<usize>(a, name, "numberOfEventIndicators", "a count", pos)?
                .unwrap_or(0);
        }
        self.md.fmi_version = version;
        self.md.model_name = self.required(a, name, "modelName", pos)?.to_owned();
        self.md.guid = self.required(a, name, token, pos)?.to_owned();
        self.md.description = attr(a, "description").map(str::to_owned);
        self.md.generation_tool = attr(a, "generationTool").map(str::to_owned);
        Ok(standard)
    }

    pub(super) fn open(
        &mut self,
        standard: Option<&mut (dyn Standard + 'static)>,
        name: &str,
        a: &Attrs,
        pos: usize,
    ) -> Result<(), ImportError> {
        let depth = self.stack.len();
        match (depth, name) {
            (1, "CoSimulation") => self.co_simulation(a, pos),
            (1, "ModelExchange") => self.model_exchange(a, pos),
            (1, "ScheduledExecution") => self.scheduled_execution(a, pos),
            (3, "Unknown")
                if self.stack[1] == "ModelStructure" && self.stack[2] == "Derivatives" =>
            {
                let index = self.number::<u32>(a, "Unknown", "index", "an index", pos)?;
                let index = index.ok_or_else(|| {
                    self.error(pos, "<Derivatives><Unknown> lacks the required attribute index")
                })?;
                self.structure_derivatives.push((index, pos));
                Ok(())
            }
            (2, "ContinuousStateDerivative") if self.stack[1] == "ModelStructure" => {
                let vr = self.value_reference(a, name, pos)?;
                self.structure_derivatives.push((vr, pos));
                Ok(())
            }
            (2, "EventIndicator") if self.stack[1] == "ModelStructure" => {
                self.event_indicators += 1;
                Ok(())
            }
            (1, "DefaultExperiment") => {
                let n = |k| self.number::<f64>(a, name, k, "a number", pos);
                self.md.default_experiment = Some(DefaultExperiment {
                    start_time: n("startTime")?,
                    stop_time: n("stopTime")?,
                    tolerance: n("tolerance")?,
                    step_size: n("stepSize")?,
                });
                Ok(())
            }
            (2.., _) if self.stack[1] == "ModelVariables" => match standard {
                Some(s) => s.open(self, &Element { depth, name, attrs: a, pos }),
                None => Ok(()),
            },
            // Everything else: annotations, units, type definitions, log categories, model
            // structure, vendor extensions.
            _ => Ok(()),
        }
    }

    pub(super) fn close(
        &mut self,
        standard: Option<&mut (dyn Standard + 'static)>,
        name: &str,
        pos: usize,
    ) -> Result<(), ImportError> {
        // `self.stack` no longer holds `name`: a child of <ModelVariables> closes at depth 2.
        let depth = self.stack.len();
        match standard {
            Some(s) if depth >= 2 && self.stack[1] == "ModelVariables" => {
                s.close(self, &Element { depth, name, attrs: &Vec::new(), pos })
            }
            _ => Ok(()),
        }
    }

    /// The `modelIdentifier` of `<CoSimulation>` or `<ModelExchange>` (`tag`).
    pub(super) fn model_identifier(
        &self,
        a: &Attrs,
        tag: &str,
        pos: usize,
    ) -> Result<String, ImportError> {
        let model_identifier = self.required(a, tag, "modelIdentifier", pos)?.trim().to_owned();
        if model_identifier.is_empty() {
            return Err(self.error(pos, format!("<{tag}> has an empty modelIdentifier")));
        }
        // It names the binary to dlopen: a path in it would load a library from outside
        // the FMU.
        if !plain_file_name(&model_identifier) {
            return Err(self.error(
                pos,
                format!("<{tag}> modelIdentifier=\"{}\" is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused", cut(&model_identifier, 200)),
            ));
        }
        Ok(model_identifier)
    }

    pub(super) fn model_exchange(&mut self, a: &Attrs, pos: usize) -> Result<(), ImportError> {
        const TAG: &str = "ModelExchange";
        if self.md.model_exchange.is_some() {
            return Err(self.error(pos, "a second <ModelExchange>"));
        }
        let model_identifier = self.model_identifier(a, TAG, pos)?;
        let (get_set, serialize) = self.state_flags;
        let flag = |k| self.boolean(a, TAG, k, pos);
        // FMI 2.0 spells it in the singular, FMI 3.0 in the plural.
        let directional =
            flag("providesDirectionalDerivative")? || flag("providesDirectionalDerivatives")?;
        let me = ModelExchange {
            model_identifier,
            needs_execution_tool: flag("needsExecutionTool")?,
            completed_integrator_step_not_needed: flag("completedIntegratorStepNotNeeded")?,
            can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
            can_get_and_set_fmu_state: flag(get_set)?,
            can_serialize_fmu_state: flag(serialize)?,
            provides_directional_derivative: directional,
            number_of_event_indicators: 0,
            states: Vec::new(),
        };
        self.md.has_model_exchange = true;
        self.md.model_exchange = Some(me);
        Ok(())
    }

    pub(super) fn co_simulation(&mut self, a: &Attrs, pos: usize) -> Result<(), ImportError> {
        const TAG: &str = "CoSimulation";
        if self.md.co_simulation.is_some() {
            return Err(self.error(pos, "a second <CoSimulation>"));
        }
        let model_identifier = self.model_identifier(a, TAG, pos)?;
        let (get_set, serialize) = self.state_flags;
        let flag = |k| self.boolean(a, TAG, k, pos);
        self.md.co_simulation = Some(CoSimulation {
            model_identifier,
            needs_execution_tool: flag("needsExecutionTool")?,
            can_handle_variable_communication_step_size: flag(
                "canHandleVariableCommunicationStepSize",
            )?,
            can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
            can_get_and_set_fmu_state: flag(get_set)?,
            can_serialize_fmu_state: flag(serialize)?,
            has_event_mode: flag("hasEventMode")?,
        });
        Ok(())
    }

    /// FMI 3.0 `<ScheduledExecution>`.
    pub(super) fn scheduled_execution(&mut self, a: &Attrs, pos: usize) -> Result<(), ImportError> {
        const TAG: &str = "ScheduledExecution";
        if self.md.scheduled_execution.is_some() {
            return Err(self.error(pos, "a second <ScheduledExecution>"));
        }
        let model_identifier = self.model_identifier(a, TAG, pos)?;
        let (get_set, serialize) = self.state_flags;
        let flag = |k| self.boolean(a, TAG, k, pos);
        self.md.scheduled_execution = Some(ScheduledExecution {
            model_identifier,
            needs_execution_tool: flag("needsExecutionTool")?,
            can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
            can_get_and_set_fmu_state: flag(get_set)?,
            can_serialize_fmu_state: flag(serialize)?,
        });
        Ok(())
    }
}
