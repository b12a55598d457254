//! placeholder
pub struct TriangleBvh; pub struct RayHit; pub struct SurfacePoint;
