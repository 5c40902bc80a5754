//! What `#[derive(Declare)]` generates: fields in declaration order, value-reference
//! offsets with the gaps `at` leaves, arrays one variable per element, flattened structs
//! spliced in with their own offsets, handles that find each field, the start values.

use inchworm_declare::{Access, Declare, Declared, Role, Start};

#[derive(Clone, Debug, PartialEq, Declare)]
pub struct Inner {
    /// Inner gain
    #[var(name = "inner_gain", start = 0.5, min = 0.0, max = 1.0)]
    pub gain: f64,
    /// Inner flag
    #[var(start = true)]
    pub flag: bool,
}

const PEAKS: [f64; 3] = [1.0, 2.0, 3.0];

#[derive(Clone, Debug, PartialEq, Declare)]
pub struct Outer {
    /// Stiffness of the mount
    ///
    /// A second paragraph, for the Rust docs only.
    #[var(unit = "N/m", start = 2.0e4, min = 0.0, max = 1e9)]
    pub k: f64,
    #[var(flatten)]
    pub inner: Inner,
    /// Peaks of the basis
    #[var(at = 10, unit = "m", start = PEAKS, element = "Peak {k}")]
    pub peaks: [f64; 3],
    /// Samples per step
    #[var(start = 100)]
    pub samples: u32,
    /// DAC volts
    #[var(input, start = 0.0, quantity = "DAC volts", range_name = "DAC range")]
    pub dac: f64,
    #[var(skip)]
    pub cache: Vec<f64>,
}

#[test]
fn fields_come_in_declaration_order_with_their_offsets() {
    let names: Vec<_> = Outer::FIELDS.iter().map(|f| (f.name, f.offset)).collect();
    assert_eq!(
        names,
        [
            ("k", 0),
            ("inner_gain", 1),
            ("flag", 2),
            ("peaks[1]", 10),
            ("peaks[2]", 11),
            ("peaks[3]", 12),
            ("samples", 13),
            ("dac", 14)
        ]
    );
    assert_eq!((Outer::N_FIELDS, Outer::SPAN, Inner::SPAN), (8, 15, 2));
}

#[test]
fn a_field_says_what_its_attribute_and_first_doc_paragraph_say() {
    let k = &Outer::FIELDS[Outer::K.index()];
    assert_eq!(k.description, "Stiffness of the mount");
    assert_eq!(
        (k.unit, k.min, k.max, k.start),
        (Some("N/m"), Some(0.0), Some(1e9), Start::Real(2e4))
    );
    assert_eq!(k.role, Role::Parameter);
    let peaks = Outer::PEAKS.field();
    assert_eq!((peaks.description, peaks.array), ("Peak 1", Some("Peaks of the basis")));
    assert_eq!(Outer::FIELDS[Outer::PEAKS.index() + 2].description, "Peak 3");
    assert_eq!(Outer::FIELDS[Outer::PEAKS.index() + 2].array, None);
    let dac = Outer::DAC.field();
    assert_eq!((dac.role, dac.wording), (Role::Input, Some(("DAC volts", "DAC range"))));
    assert_eq!(Outer::SAMPLES.field().start, Start::Integer(100));
}

#[test]
fn a_flattened_field_is_reached_through_the_outer_struct() {
    let gain = Outer::inner(Inner::GAIN);
    assert_eq!(gain.name(), "inner_gain");
    let mut o = Outer::declared();
    assert_eq!(o.inner, Inner { gain: 0.5, flag: true });
    match gain.field().access {
        Access::Real { get, set } => {
            set(&mut o, 0.25);
            assert_eq!((get(&o), o.inner.gain), (0.25, 0.25));
        }
        _ => panic!("inner_gain is a Real"),
    }
    assert_eq!(Outer::inner(Inner::FLAG).name(), "flag");
}

#[test]
fn declared_is_every_start_value() {
    let o = Outer::declared();
    assert_eq!((o.k, o.peaks, o.samples, o.dac), (2e4, PEAKS, 100, 0.0));
    assert!(o.cache.is_empty());
    let bad = Outer { inner: Inner { gain: 2.0, ..Inner::declared() }, ..Outer::declared() };
    let (name, why) = inchworm_declare::out_of_range(&bad).unwrap();
    assert_eq!(
        (name, why.as_str()),
        ("inner_gain", "must be within [0e0, 1e0] (dimensionless), got 2e0")
    );
}

#[test]
fn set_named_parses_each_type_and_refuses_what_is_not_declared() {
    use inchworm_declare::set_named;
    let mut o = Outer::declared();
    set_named(&mut o, "k", "3e4").unwrap();
    set_named(&mut o, "inner_gain", " 0.25 ").unwrap();
    set_named(&mut o, "flag", "0").unwrap();
    set_named(&mut o, "peaks[2]", "7").unwrap();
    set_named(&mut o, "samples", "40").unwrap();
    assert_eq!(
        (o.k, o.inner.gain, o.inner.flag, o.peaks, o.samples),
        (3e4, 0.25, false, [1.0, 7.0, 3.0], 40)
    );
    let before = o.clone();
    for (name, text, says) in [
        ("inner_gain", "1.5", "inner_gain = 1.5: must be finite, within [0e0, 1e0]"),
        ("k", "NaN", "k = NaN: must be finite"),
        ("k", "ten", "k = ten: not a number"),
        ("samples", "2.5", "samples = 2.5: not a 32-bit integer"),
        ("flag", "yes", "flag = yes: not true, false, 1 or 0"),
        ("nope", "1", "unknown parameter `nope`; known: k, inner_gain, flag, peaks[1]"),
    ] {
        let e = set_named(&mut o, name, text).unwrap_err();
        assert!(e.starts_with(says), "{name}={text}: {e}");
    }
    assert_eq!(o, before, "a refused value changes nothing");
}

#[test]
fn an_array_field_s_base_name_has_no_index() {
    assert_eq!(Outer::PEAKS.name(), "peaks[1]");
    assert_eq!(Outer::PEAKS.base_name(), "peaks");
    assert_eq!(Outer::K.base_name(), "k");
}
