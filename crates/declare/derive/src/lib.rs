//! `#[derive(Declare)]` for `inchworm-declare`: reads the `#[var(...)]` attribute and the
//! doc comment of every field of a struct and generates its `Declared` impl, the generic
//! `fields_in::<M>()` through which a model holding the struct reaches the fields, a
//! `FieldId` constant per field (the field's name in upper case) and `N_FIELDS`.

use proc_macro::TokenStream;
use proc_macro2::{Span, TokenStream as Tokens};
use quote::{format_ident, quote};
use syn::{
    parse_macro_input, Data, DeriveInput, Expr, ExprArray, ExprLit, Fields, Ident, Lit, LitStr,
    Type,
};

#[proc_macro_derive(Declare, attributes(var))]
pub fn derive_declare(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match expand(&input) {
        Ok(tokens) => tokens.into(),
        Err(e) => e.to_compile_error().into(),
    }
}

/// What one field's attribute and doc comment say.
struct Decl {
    field: Ident,
    ty: Type,
    name: String,
    description: String,
    unit: Option<LitStr>,
    start: Option<Expr>,
    min: Option<Expr>,
    max: Option<Expr>,
    input: bool,
    quantity: Option<LitStr>,
    range_name: Option<LitStr>,
    elements: Option<Vec<LitStr>>,
    /// `element = "… {k} …"`: an array element's description, `{k}` its number from 1.
    element: Option<LitStr>,
    /// `at = n`: the field's value reference is the part's base + n (a gap before it).
    at: Option<u32>,
    /// `flatten`: the field is a declared struct whose fields are spliced in here.
    flatten: bool,
    skip: bool,
}

/// The FMI type a field's Rust type maps to.
enum Kind {
    Real,
    Boolean,
    Integer,
    /// `[f64; n]`: n Real elements.
    RealArray,
}

fn kind_of(ty: &Type) -> Kind {
    match ty {
        Type::Array(_) => Kind::RealArray,
        Type::Path(p) if p.path.is_ident("f64") => Kind::Real,
        Type::Path(p) if p.path.is_ident("bool") => Kind::Boolean,
        _ => Kind::Integer,
    }
}

/// The first paragraph of the doc comment, its lines joined: the variable's description
/// (further paragraphs document the Rust field only).
fn doc_of(attrs: &[syn::Attribute]) -> String {
    let mut lines = Vec::new();
    for a in attrs.iter().filter(|a| a.path().is_ident("doc")) {
        if let syn::Meta::NameValue(nv) = &a.meta {
            if let Expr::Lit(ExprLit { lit: Lit::Str(s), .. }) = &nv.value {
                let line = s.value();
                let line = line.trim();
                if line.is_empty() {
                    if lines.is_empty() {
                        continue;
                    }
                    break;
                }
                lines.push(line.to_string());
            }
        }
    }
    lines.join(" ")
}

fn parse_field(f: &syn::Field) -> syn::Result<Decl> {
    let field = f.ident.clone().ok_or_else(|| syn::Error::new_spanned(f, "a named field"))?;
    let mut d = Decl {
        name: field.to_string(),
        field,
        ty: f.ty.clone(),
        description: doc_of(&f.attrs),
        unit: None,
        start: None,
        min: None,
        max: None,
        input: false,
        quantity: None,
        range_name: None,
        elements: None,
        element: None,
        at: None,
        flatten: false,
        skip: false,
    };
    let mut seen = false;
    for a in f.attrs.iter().filter(|a| a.path().is_ident("var")) {
        seen = true;
        a.parse_nested_meta(|meta| {
            let key = meta.path.get_ident().map(|i| i.to_string()).unwrap_or_default();
            match key.as_str() {
                "name" => d.name = meta.value()?.parse::<LitStr>()?.value(),
                "unit" => d.unit = Some(meta.value()?.parse()?),
                "start" => d.start = Some(meta.value()?.parse()?),
                "min" => d.min = Some(meta.value()?.parse()?),
                "max" => d.max = Some(meta.value()?.parse()?),
                "input" => d.input = true,
                "skip" => d.skip = true,
                "flatten" => d.flatten = true,
                "at" => d.at = Some(meta.value()?.parse::<syn::LitInt>()?.base10_parse()?),
                "element" => d.element = Some(meta.value()?.parse()?),
                "quantity" => d.quantity = Some(meta.value()?.parse()?),
                "range_name" => d.range_name = Some(meta.value()?.parse()?),
                "elements" => {
                    let array: ExprArray = meta.value()?.parse()?;
                    let mut out = Vec::new();
                    for e in array.elems {
                        match e {
                            Expr::Lit(ExprLit { lit: Lit::Str(s), .. }) => out.push(s),
                            other => {
                                return Err(syn::Error::new_spanned(other, "a string literal"))
                            }
                        }
                    }
                    d.elements = Some(out);
                }
                _ => return Err(meta.error("unknown key of #[var]: name, unit, start, min, max, input, skip, flatten, at, quantity, range_name, elements, element")),
            }
            Ok(())
        })?;
    }
    if !seen {
        return Err(syn::Error::new_spanned(
            &d.field,
            "every field of a declared struct has its #[var(...)] (or #[var(skip)])",
        ));
    }
    if !d.skip && !d.flatten {
        if d.start.is_none() {
            return Err(syn::Error::new_spanned(
                &d.field,
                "#[var] needs the start value: start = ...",
            ));
        }
        if d.description.is_empty() {
            return Err(syn::Error::new_spanned(
                &d.field,
                "a declared field's doc comment is its description: it has none",
            ));
        }
    }
    Ok(d)
}

fn opt_str(s: &Option<LitStr>) -> Tokens {
    match s {
        Some(s) => quote!(::core::option::Option::Some(#s)),
        None => quote!(::core::option::Option::None),
    }
}

fn opt_f64(e: &Option<Expr>) -> Tokens {
    match e {
        Some(e) => quote!(::core::option::Option::Some((#e) as f64)),
        None => quote!(::core::option::Option::None),
    }
}

/// A run of the struct's own variables, or a flattened struct's (its type, and the
/// value-reference offset its variables start at).
enum Segment {
    Own(Vec<Tokens>),
    Nested(Box<Type>, Tokens),
}

fn expand(input: &DeriveInput) -> syn::Result<Tokens> {
    let ty = &input.ident;
    let fields = match &input.data {
        Data::Struct(s) => match &s.fields {
            Fields::Named(n) => &n.named,
            _ => return Err(syn::Error::new_spanned(ty, "Declare needs named fields")),
        },
        _ => return Err(syn::Error::new_spanned(ty, "Declare is for structs")),
    };
    let decls = fields.iter().map(parse_field).collect::<syn::Result<Vec<_>>>()?;
    let krate = quote!(::inchworm_declare);

    let mut segments: Vec<Segment> = Vec::new();
    let own = |segments: &mut Vec<Segment>, entry: Tokens| match segments.last_mut() {
        Some(Segment::Own(v)) => v.push(entry),
        _ => segments.push(Segment::Own(vec![entry])),
    };
    let mut ids = Vec::new();
    let mut inits = Vec::new();
    let mut has = Vec::new();
    let mut nested_types: Vec<Type> = Vec::new();
    let mut checks = Vec::new();
    // The running index into FIELDS and value-reference offset, as const expressions.
    let mut index = quote!(0usize);
    let mut offset = quote!(0u32);
    for d in &decls {
        let field = &d.field;
        if d.skip {
            inits.push(quote!(#field: ::core::default::Default::default()));
            continue;
        }
        if let Some(at) = d.at {
            let message = format!("`at = {at}` on {field} is below the value references before it");
            checks.push(quote!(assert!(#at >= #offset, #message);));
            offset = quote!(#at);
        }
        if d.flatten {
            let nty = &d.ty;
            inits.push(quote!(#field: <#nty as #krate::Declared>::declared()));
            has.push(quote! {
                impl #krate::Has<#nty> for #ty {
                    fn part(&self) -> &#nty {
                        &self.#field
                    }
                    fn part_mut(&mut self) -> &mut #nty {
                        &mut self.#field
                    }
                }
            });
            let doc = format!("The handle in `{ty}` of a field of its flattened `{field}`.");
            ids.push(quote! {
                #[doc = #doc]
                #[allow(dead_code)]
                pub const fn #field(id: #krate::FieldId<#nty>) -> #krate::FieldId<#ty> {
                    #krate::FieldId::at(#index + id.index())
                }
            });
            segments.push(Segment::Nested(Box::new(nty.clone()), offset.clone()));
            nested_types.push(nty.clone());
            index = quote!((#index + <#nty>::N_FIELDS));
            offset = quote!((#offset + <#nty>::SPAN));
            continue;
        }
        let start = d.start.as_ref().expect("checked");
        let id = format_ident!("{}", d.field.to_string().to_uppercase());
        ids.push(quote! {
            #[allow(dead_code)]
            pub const #id: #krate::FieldId<#ty> = #krate::FieldId::at(#index);
        });
        let role =
            if d.input { quote!(#krate::Role::Input) } else { quote!(#krate::Role::Parameter) };
        let (unit, min, max) = (opt_str(&d.unit), opt_f64(&d.min), opt_f64(&d.max));
        let wording = match (&d.quantity, &d.range_name) {
            (Some(q), Some(r)) => quote!(::core::option::Option::Some((#q, #r))),
            (None, None) => quote!(::core::option::Option::None),
            _ => return Err(syn::Error::new_spanned(field, "quantity and range_name go together")),
        };
        let entry = |name: String,
                     description: String,
                     array: Tokens,
                     start: Tokens,
                     access: Tokens,
                     offset: &Tokens| {
            let (name, description) = (
                LitStr::new(&name, Span::call_site()),
                LitStr::new(&description, Span::call_site()),
            );
            quote! {
                #krate::Field {
                    name: #name,
                    role: #role,
                    description: #description,
                    unit: #unit,
                    start: #start,
                    min: #min,
                    max: #max,
                    array: #array,
                    wording: #wording,
                    offset: #offset,
                    access: #access,
                }
            }
        };
        let none = quote!(::core::option::Option::None);
        let scalar = |access: Tokens, start: Tokens| {
            entry(d.name.clone(), d.description.clone(), none.clone(), start, access, &offset)
        };
        match kind_of(&d.ty) {
            Kind::Real => {
                inits.push(quote!(#field: #start));
                let access = quote!(#krate::Access::Real {
                    get: |m: &M| #krate::Has::<#ty>::part(m).#field,
                    set: |m: &mut M, x: f64| #krate::Has::<#ty>::part_mut(m).#field = x,
                });
                own(&mut segments, scalar(access, quote!(#krate::Start::Real(#start))));
                index = quote!((#index + 1));
                offset = quote!((#offset + 1));
            }
            Kind::Boolean => {
                inits.push(quote!(#field: #start));
                let access = quote!(#krate::Access::Boolean {
                    get: |m: &M| #krate::Has::<#ty>::part(m).#field,
                    set: |m: &mut M, x: bool| #krate::Has::<#ty>::part_mut(m).#field = x,
                });
                own(&mut segments, scalar(access, quote!(#krate::Start::Boolean(#start))));
                index = quote!((#index + 1));
                offset = quote!((#offset + 1));
            }
            Kind::Integer => {
                inits.push(quote!(#field: #start));
                let fty = &d.ty;
                let access = quote!(#krate::Access::Integer {
                    get: |m: &M| #krate::IntegerField::to_fmi(#krate::Has::<#ty>::part(m).#field),
                    set: |m: &mut M, x: i32| #krate::Has::<#ty>::part_mut(m).#field = <#fty as #krate::IntegerField>::from_fmi(x),
                });
                let start = quote!(#krate::Start::Integer((#start) as i32));
                own(&mut segments, scalar(access, start));
                index = quote!((#index + 1));
                offset = quote!((#offset + 1));
            }
            Kind::RealArray => {
                // The elements' starts: an array literal's, or a constant's elements (the
                // type's length then a literal).
                let starts: Vec<Tokens> = match start {
                    Expr::Array(a) => a.elems.iter().map(|e| quote!(#e)).collect(),
                    other => {
                        let n = array_len(&d.ty).ok_or_else(|| {
                            syn::Error::new_spanned(
                                other,
                                "an array field's start is an array literal [a, b, ...], or a constant when its type's length is a literal",
                            )
                        })?;
                        (0..n).map(|k| quote!((#other)[#k])).collect()
                    }
                };
                inits.push(quote!(#field: [#(#starts),*]));
                if let Some(el) = &d.elements {
                    if el.len() != starts.len() {
                        return Err(syn::Error::new_spanned(
                            field,
                            "elements has one description per element of start",
                        ));
                    }
                }
                for (k, s) in starts.iter().enumerate() {
                    let element = match (&d.elements, &d.element) {
                        (Some(el), _) => el[k].value(),
                        (None, Some(t)) => t.value().replace("{k}", &(k + 1).to_string()),
                        (None, None) => d.description.clone(),
                    };
                    let array = if k == 0 {
                        let whole = LitStr::new(&d.description, Span::call_site());
                        quote!(::core::option::Option::Some(#whole))
                    } else {
                        none.clone()
                    };
                    let access = quote!(#krate::Access::Real {
                        get: |m: &M| #krate::Has::<#ty>::part(m).#field[#k],
                        set: |m: &mut M, x: f64| #krate::Has::<#ty>::part_mut(m).#field[#k] = x,
                    });
                    let name = format!("{}[{}]", d.name, k + 1);
                    let start = quote!(#krate::Start::Real(#s));
                    own(&mut segments, entry(name, element, array, start, access, &offset));
                    offset = quote!((#offset + 1));
                }
                let n = starts.len();
                index = quote!((#index + #n));
            }
        }
    }

    // The fields, in declaration order: one array literal when the struct flattens none,
    // else its segments copied one after another.
    let body = match segments.as_slice() {
        [] => quote!([]),
        [Segment::Own(entries)] => quote!([#(#entries),*]),
        _ => {
            let mut lets = Vec::new();
            let mut copies = Vec::new();
            for (i, seg) in segments.iter().enumerate() {
                let name = format_ident!("segment{}", i);
                let (array, base) = match seg {
                    Segment::Own(entries) => (quote!([#(#entries),*]), quote!(0u32)),
                    Segment::Nested(nty, base) => (quote!(<#nty>::fields_in::<M>()), base.clone()),
                };
                lets.push(quote!(let #name = #array;));
                copies.push(quote! {
                    let mut i = 0;
                    while i < #name.len() {
                        let mut f = #name[i];
                        f.offset += #base;
                        out[at] = f;
                        at += 1;
                        i += 1;
                    }
                });
            }
            quote! {{
                #(#lets)*
                let mut out = [segment0[0]; Self::N_FIELDS];
                let mut at = 0usize;
                #(#copies)*
                assert!(at == Self::N_FIELDS);
                out
            }}
        }
    };
    let bounds = quote!(#krate::Has<#ty> #(+ #krate::Has<#nested_types>)*);
    Ok(quote! {
        impl #ty {
            /// The number of declared variables (an array's elements each one).
            pub const N_FIELDS: usize = #index;
            /// The value references the variables span from the part's base (gaps
            /// included).
            pub const SPAN: u32 = #offset;
            /// The declared variables as a model `M` holding this part reaches them.
            pub const fn fields_in<M: #bounds>() -> [#krate::Field<M>; Self::N_FIELDS] {
                #body
            }
            #(#ids)*
        }
        const _: () = { #(#checks)* };
        #(#has)*
        impl #krate::Declared for #ty {
            const FIELDS: &'static [#krate::Field<Self>] = &Self::fields_in::<Self>();
            fn declared() -> Self {
                #ty { #(#inits),* }
            }
        }
    })
}

/// The length of an array type whose length is an integer literal.
fn array_len(ty: &Type) -> Option<usize> {
    match ty {
        Type::Array(a) => match &a.len {
            Expr::Lit(ExprLit { lit: Lit::Int(n), .. }) => n.base10_parse().ok(),
            _ => None,
        },
        _ => None,
    }
}
