"""The analysis stage: what judges measure, read off the target's 3D skeleton (flights, saltos,
twists, shapes, holds, landings, circles, turns). Paper: Section III-D, last paragraph, Fig. 8."""
