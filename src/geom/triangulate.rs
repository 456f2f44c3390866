//! Triangulation of simple planar polygons (OBJ n-gons, USD faces).
