/* MERL BRDF tables (.binary; Matusik, Pfister, Brand, McMillan, "A
 * Data-Driven Reflectance Model", TOG 22(3), 2003). Layout (design brief
 * section 4): three LE int32 (90, 90, 180), then 3 x 1,458,000 LE float64,
 * planar R, G, B, index k + 180 (j + 90 i) for cell (theta_h i, theta_d j,
 * phi_d k) at theta_h = (i/90)^2 pi/2, theta_d = j/90 pi/2, phi_d = k/180 pi.
 * Stored values are BRDF / scale with scales R 1/1500, G 1.15/1500,
 * B 1.66/1500; negative values mark cells without a measurement. */
#ifndef GONIO_BRDF_MERL_H
#define GONIO_BRDF_MERL_H

#include <stddef.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "common/err.h"

#define BRDF_MERL_NTH 90
#define BRDF_MERL_NTD 90
#define BRDF_MERL_NPD 180
#define BRDF_MERL_CELLS (BRDF_MERL_NTH * BRDF_MERL_NTD * BRDF_MERL_NPD)
#define BRDF_MERL_FILE_BYTES (12 + 3 * (size_t)BRDF_MERL_CELLS * 8)

extern const double brdf_merl_scale[3];

/* The grid node of cell (i, j, k), radians. */
void brdf_merl_node(int i, int j, int k, double *theta_h, double *theta_d, double *phi_d);

/* The cell a pair falls in (floor bins as MERL's reference code, with a
 * 1e-9-bin allowance so a query at a node lands in that node's cell). */
size_t brdf_merl_cell(double theta_h, double theta_d, double phi_d);

/* Read a table: data[3 * BRDF_MERL_CELLS] as stored (not scaled). Refuses
 * a wrong header or size, a short read and NaN/Inf values; the message
 * names the file. The caller frees *data. */
int brdf_merl_read(const char *path, double **data, struct gonio_err *err);

/* A material over the table in path (name: what brdf_material_name says;
 * the path when NULL). No-data cells evaluate to NAN. */
brdf_material *brdf_merl_open(const char *path, const char *name, struct gonio_err *err);

/* Tabulate m at every grid node into a MERL table at path, written
 * atomically. Nodes where wi or wo is at or below the horizon, or where m
 * has no data, get -1. */
int brdf_merl_export(const brdf_material *m, const char *path, struct gonio_err *err);

#endif
