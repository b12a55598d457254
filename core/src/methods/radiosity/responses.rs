//! A radiosity session's solutions as linear combinations (design/radiosity.md §1.6): the
//! solution of one source (a light at unit strength, or the emission), their weighted sums, and
//! where a new light's solve starts.

use crate::light::Light;

/// One translucent object's share of a solution: the source q of its last diffusion solve and
/// the fluence φ it gave.
#[derive(Debug, Clone)]
pub(super) struct Field {
    pub(super) source: Vec<[f64; 3]>,
    pub(super) fluence: Vec<[f64; 3]>,
}

/// The scene's solution for one set of sources: B per patch and each translucent object's
/// field (`None` for opaque objects). Linear in the sources.
#[derive(Debug, Clone)]
pub(super) struct Response {
    pub(super) radiosity: Vec<[f64; 3]>,
    pub(super) fields: Vec<Option<Field>>,
}

impl Response {
    /// The response of nothing, shaped as `like`.
    pub(super) fn zero_like(like: &Response) -> Response {
        let zero = |v: &[[f64; 3]]| vec![[0.0; 3]; v.len()];
        Response {
            radiosity: zero(&like.radiosity),
            fields: like
                .fields
                .iter()
                .map(|f| f.as_ref().map(|f| Field { source: zero(&f.source), fluence: zero(&f.fluence) }))
                .collect(),
        }
    }

    /// `self += s ⊙ other`, per channel.
    pub(super) fn add_scaled(&mut self, s: [f64; 3], other: &Response) {
        let axpy = |y: &mut [[f64; 3]], x: &[[f64; 3]]| {
            for (y, x) in y.iter_mut().zip(x) {
                for c in 0..3 {
                    y[c] += s[c] * x[c];
                }
            }
        };
        axpy(&mut self.radiosity, &other.radiosity);
        for (mine, theirs) in self.fields.iter_mut().zip(&other.fields) {
            if let (Some(m), Some(t)) = (mine, theirs) {
                axpy(&mut m.source, &t.source);
                axpy(&mut m.fluence, &t.fluence);
            }
        }
    }

    /// `self` with each channel divided by `s` (every channel > 0).
    pub(super) fn divided(&self, s: [f64; 3]) -> Response {
        let mut out = Response::zero_like(self);
        out.add_scaled(s.map(|x| 1.0 / x), self);
        out
    }
}

/// What a cached response is the solution of.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Source {
    /// A light at unit strength ([`Light::split_strength`]).
    Light(Light),
    /// The emission of the diffuse objects.
    Emission,
}

/// Where the solve of `source` starts: the response (among `responses`) of the light that had
/// its place in the last lights `before` (a light being moved); none for a light without one,
/// for the emission, or for a count of bounces (which starts from no light).
pub(super) fn warm_start<'a>(
    responses: &'a [(Source, Response)],
    before: &[Light],
    bounces: Option<usize>,
    source: &Source,
    lights: &[Light],
) -> Option<&'a Response> {
    if bounces.is_some() {
        return None;
    }
    let Source::Light(unit) = source else { return None };
    let place = lights.iter().position(|l| &l.split_strength().0 == unit)?;
    let old = Source::Light(before.get(place)?.split_strength().0);
    responses.iter().find(|(s, _)| *s == old).map(|(_, r)| r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn response(scale: f64) -> Response {
        Response {
            radiosity: vec![[scale, 2.0 * scale, 3.0 * scale]; 2],
            fields: vec![None, Some(Field { source: vec![[scale; 3]], fluence: vec![[4.0 * scale; 3]; 3] })],
        }
    }

    #[test]
    fn responses_combine_per_channel() {
        let mut sum = Response::zero_like(&response(1.0));
        sum.add_scaled([1.0, 2.0, 0.5], &response(1.0));
        sum.add_scaled([3.0; 3], &response(2.0));
        assert_eq!(sum.radiosity[1], [7.0, 16.0, 19.5]);
        let field = sum.fields[1].as_ref().unwrap();
        assert_eq!((field.source[0], field.fluence[2]), ([7.0, 8.0, 6.5], [28.0, 32.0, 26.0]));
        assert!(sum.fields[0].is_none());
        assert_eq!(response(6.0).divided([2.0, 3.0, 6.0]).radiosity[0], [3.0, 4.0, 3.0]);
    }

    #[test]
    fn a_moved_light_starts_from_the_one_in_its_place() {
        let at = |z: f64, i: f64| Light::Point { position: DVec3::new(0.0, 0.0, z), intensity: [i; 3] };
        let unit = |l: &Light| Source::Light(l.split_strength().0);
        let responses = vec![(unit(&at(1.0, 1.0)), response(1.0)), (unit(&at(2.0, 1.0)), response(2.0))];
        let before = [at(1.0, 5.0), at(2.0, 7.0)];
        // The second light moved: its solve starts from the second light's response.
        let lights = [at(1.0, 5.0), at(3.0, 7.0)];
        let start = warm_start(&responses, &before, None, &unit(&lights[1]), &lights).unwrap();
        assert_eq!(start.radiosity[0][0], 2.0);
        assert!(warm_start(&responses, &before, Some(3), &unit(&lights[1]), &lights).is_none(), "bounces start cold");
        assert!(warm_start(&responses, &before, None, &Source::Emission, &lights).is_none());
        let more = [at(1.0, 5.0), at(2.0, 7.0), at(9.0, 1.0)];
        assert!(warm_start(&responses, &before, None, &unit(&more[2]), &more).is_none(), "a new light has no place");
    }
}
