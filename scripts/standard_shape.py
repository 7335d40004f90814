#!/usr/bin/python3
"""The angular shape table of configs/standards/spectralon-99.yaml: a smooth
form with the features published for pressed-PTFE (Spectralon) standards,
not a measurement. For normal incidence the reflectance factor falls from
1.01 at normal view to 0.91 at 60 deg (-10 %, as PTB's multi-geometry
measurements show: Hoepe & Hauer, Metrologia 47 (2010) 295) and on to 0.79
at 85 deg; oblique incidence lifts the mirror side and lowers the back side
(forward scattering), more the more grazing both angles are. A real
standard's certificate replaces the table.

Run: python3 scripts/standard_shape.py  (prints the YAML block)"""

INCIDENCE = [0, 15, 30, 45, 60, 75]
VIEW = [-85, -75, -60, -45, -30, -15, 0, 15, 30, 45, 60, 75, 85]


def normal_incidence(view_deg):
    v = abs(view_deg)
    if v <= 60:
        return 1.01 - 0.10 * (v / 60.0) ** 2
    return 0.91 - 0.12 * ((v - 60) / 25.0) ** 1.2


def factor(inc_deg, view_deg):
    lift = 0.20 * (inc_deg / 75.0) ** 2
    side = (abs(view_deg) / 85.0) ** 2 * (1.0 if view_deg > 0 else -0.4)
    return normal_incidence(view_deg) * (1.0 + lift * side)


def main():
    print("  incidence_deg: [" + ", ".join(str(i) for i in INCIDENCE) + "]")
    print("  view_deg: [" + ", ".join(str(v) for v in VIEW) + "]")
    print("  factor:")
    for i in INCIDENCE:
        print("    - [" + ", ".join("%.3f" % factor(i, v) for v in VIEW) + "]")


if __name__ == "__main__":
    main()
