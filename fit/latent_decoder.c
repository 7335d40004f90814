/* The decoder object: layout, weight file, evaluation and materials. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zlib.h>

#include "brdf/material_private.h"
#include "common/paths.h"
#include "fit/latent_private.h"

#define LATENT_MAGIC "gonio-latent-decoder"

const char *const latent_heldout_materials[10] = {
    "nylon", "tungsten-carbide", "specular-black-phenolic", "blue-acrylic", "brass",
    "gold-metallic-paint", "white-diffuse-bball", "red-plastic", "alum-bronze", "pearl-paint",
};

latent_decoder *latent_decoder_alloc(int nz, int layers, int width, size_t n_materials)
{
    if (nz < 1 || nz > LATENT_MAX_NZ || layers < 1 || layers > LATENT_MAX_LAYERS ||
        width < LATENT_NOUT || width > LATENT_MAX_WIDTH)
        return NULL;
    latent_decoder *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->nz = nz;
    d->layers = layers;
    d->width = width;
    size_t off = 0;
    for (int l = 0; l <= layers; l++) {
        d->din[l] = l == 0 ? LATENT_NIN + nz : width;
        d->dout[l] = l == layers ? LATENT_NOUT : width;
        d->off_w[l] = off;
        off += (size_t)d->din[l] * (size_t)d->dout[l];
        d->off_b[l] = off;
        off += (size_t)d->dout[l];
    }
    d->n_params = off;
    d->n_materials = n_materials;
    d->params = calloc(off, sizeof *d->params);
    d->latents = calloc(n_materials * (size_t)nz + 1, sizeof *d->latents);
    d->names = calloc(n_materials + 1, sizeof *d->names);
    d->mean = calloc((size_t)nz, sizeof *d->mean);
    if (!d->params || !d->latents || !d->names || !d->mean) {
        latent_decoder_free(d);
        return NULL;
    }
    return d;
}

void latent_decoder_free(latent_decoder *d)
{
    if (!d)
        return;
    free(d->params);
    free(d->latents);
    free(d->names);
    free(d->mean);
    free(d);
}

static void put_le64(unsigned char *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    for (int i = 0; i < 8; i++)
        b[i] = (unsigned char)(u >> (8 * i));
}

static double get_le64(const unsigned char *b)
{
    uint64_t u = 0;
    for (int i = 0; i < 8; i++)
        u |= (uint64_t)b[i] << (8 * i);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

/* The data block: weights, then the latents, as little-endian binary64. */
static unsigned char *data_block(const latent_decoder *d, size_t *n_values)
{
    size_t n = d->n_params + d->n_materials * (size_t)d->nz;
    unsigned char *b = malloc(8 * n + 1);
    if (!b)
        return NULL;
    for (size_t i = 0; i < d->n_params; i++)
        put_le64(b + 8 * i, d->params[i]);
    for (size_t i = 0; i < d->n_materials * (size_t)d->nz; i++)
        put_le64(b + 8 * (d->n_params + i), d->latents[i]);
    *n_values = n;
    return b;
}

static uint32_t crc_of(const unsigned char *b, size_t len)
{
    uLong crc = crc32(0L, Z_NULL, 0);
    while (len > 0) {
        uInt chunk = len > (1u << 30) ? (1u << 30) : (uInt)len;
        crc = crc32(crc, b, chunk);
        b += chunk;
        len -= chunk;
    }
    return (uint32_t)crc;
}

void latent_decoder_refresh(latent_decoder *d)
{
    for (int k = 0; k < d->nz; k++) {
        double s = 0;
        for (size_t m = 0; m < d->n_materials; m++)
            s += d->latents[m * (size_t)d->nz + (size_t)k];
        d->mean[k] = d->n_materials ? s / (double)d->n_materials : 0.0;
    }
    d->prior_h = latent_prior_bandwidth(d);
    size_t n;
    unsigned char *b = data_block(d, &n);
    d->crc = b ? crc_of(b, 8 * n) : 0;
    free(b);
}

int latent_decoder_save(const latent_decoder *d, const char *path, struct gonio_err *err)
{
    size_t n;
    unsigned char *b = data_block(d, &n);
    char *head = NULL;
    size_t head_len = 0;
    FILE *mf = b ? open_memstream(&head, &head_len) : NULL;
    if (!mf) {
        free(b);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    const struct latent_train_options *t = &d->train;
    fprintf(mf, "%s %d\n", LATENT_MAGIC, LATENT_FILE_VERSION);
    fprintf(mf, "nin %d\nnz %d\nlayers %d\nwidth %d\nnout %d\n", LATENT_NIN, d->nz, d->layers,
            d->width, LATENT_NOUT);
    fprintf(mf, "seed %llu\nsteps %ld\nsamples_per_step %d\n", (unsigned long long)t->seed,
            t->steps, t->samples_per_step);
    fprintf(mf, "lr %.17g\nlr_z %.17g\nlambda_z %.17g\n", t->lr, t->lr_z, t->lambda_z);
    if (t->z_noise > 0) /* written only when used: older files stay valid and identical */
        fprintf(mf, "z_noise %.17g\n", t->z_noise);
    if (t->inplane > 0)
        fprintf(mf, "inplane %.17g\n", t->inplane);
    fprintf(mf, "heldout");
    for (size_t i = 0; i < 10; i++)
        fprintf(mf, " %s", latent_heldout_materials[i]);
    fprintf(mf, "\nmaterials %zu\n", d->n_materials);
    for (size_t m = 0; m < d->n_materials; m++)
        fprintf(mf, "material %s\n", d->names[m]);
    fprintf(mf, "data %zu %08x\n", n, (unsigned)crc_of(b, 8 * n));
    if (fclose(mf) != 0) {
        free(head);
        free(b);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    unsigned char *all = malloc(head_len + 8 * n);
    if (!all) {
        free(head);
        free(b);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    memcpy(all, head, head_len);
    memcpy(all + head_len, b, 8 * n);
    int rc = gonio_write_file_atomic(path, all, head_len + 8 * n, err);
    free(all);
    free(head);
    free(b);
    return rc;
}

/* Reads "KEY VALUE\n" at *pos; value copied into val. 0 or -1. */
static int next_line(const char *buf, size_t len, size_t *pos, char *key, size_t ksize,
                     char *val, size_t vsize)
{
    size_t p = *pos, e = p;
    while (e < len && buf[e] != '\n')
        e++;
    if (e >= len)
        return -1;
    size_t sp = p;
    while (sp < e && buf[sp] != ' ')
        sp++;
    if (sp == p || sp >= e || sp - p >= ksize || e - sp - 1 >= vsize)
        return -1;
    memcpy(key, buf + p, sp - p);
    key[sp - p] = '\0';
    memcpy(val, buf + sp + 1, e - sp - 1);
    val[e - sp - 1] = '\0';
    *pos = e + 1;
    return 0;
}

static int parse_long(const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

static char *read_all(const char *path, size_t *len, struct gonio_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        gonio_err_set(err, e == ENOENT ? GONIO_ENOTFOUND : e, "%s: cannot open: %s", path,
                      strerror(e));
        return NULL;
    }
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        size_t r = fread(buf + n, 1, cap - n, f);
        n += r;
        if (n < cap)
            break;
        char *nb = cap > ((size_t)64 << 20) ? NULL : realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf || bad) {
        free(buf);
        gonio_err_set(err, GONIO_EBADDATA, "%s: cannot read (error or larger than 64 MB)",
                      path);
        return NULL;
    }
    *len = n;
    return buf;
}

/* What a decoder file's header has said so far: its shape, its training
 * options and, from its 'materials' line on, the decoder they describe. */
struct decoder_header {
    const char *path;
    long nin, nz, layers, width, nout, nmat;
    unsigned long long seed;
    long steps, sps;
    double lr, lr_z, lambda_z, z_noise, inplane;
    latent_decoder *d;
    size_t m; /* material names read */
};

/* A shape or training-option line: 1 when key is one (and its value
 * valid), 0 when it is not one, < 0 for a bad value. */
static int header_setting(struct decoder_header *h, const char *key, const char *val,
                          struct gonio_err *err)
{
    const char *path = h->path;
    long *slot = !strcmp(key, "nin") ? &h->nin : !strcmp(key, "nz") ? &h->nz
               : !strcmp(key, "layers") ? &h->layers : !strcmp(key, "width") ? &h->width
               : !strcmp(key, "nout") ? &h->nout : !strcmp(key, "steps") ? &h->steps
               : !strcmp(key, "samples_per_step") ? &h->sps : NULL;
    if (slot) {
        if (parse_long(val, 0, 100000000, slot) < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: %s '%s' is not a valid count", path,
                                 key, val);
    } else if (!strcmp(key, "seed")) {
        char *end;
        errno = 0;
        unsigned long long s = strtoull(val, &end, 10);
        if (errno || end == val || *end)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: seed '%s' is not an integer", path,
                                 val);
        h->seed = s;
    } else if (!strcmp(key, "lr") || !strcmp(key, "lr_z") || !strcmp(key, "lambda_z") ||
               !strcmp(key, "z_noise") || !strcmp(key, "inplane")) {
        double v;
        if (parse_double(val, &v) < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: %s '%s' is not a finite number",
                                 path, key, val);
        *(!strcmp(key, "lr") ? &h->lr : !strcmp(key, "lr_z") ? &h->lr_z
          : !strcmp(key, "lambda_z") ? &h->lambda_z : !strcmp(key, "z_noise") ? &h->z_noise
                                                  : &h->inplane) = v;
    } else if (!strcmp(key, "heldout")) {
        /* informational: the held-out list of the build that trained it */
    } else {
        return 0;
    }
    return 1;
}

/* The 'materials N' line: the shape read so far becomes the decoder. */
static int header_materials(struct decoder_header *h, const char *val, struct gonio_err *err)
{
    const char *path = h->path;
    if (h->d) /* a second shape would replace (and leak) the first */
        return gonio_err_set(err, GONIO_EBADDATA, "%s: 'materials' given twice", path);
    if (parse_long(val, 1, 100000, &h->nmat) < 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: materials '%s' is not a valid count",
                             path, val);
    if (h->nin != LATENT_NIN || h->nout != LATENT_NOUT)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: nin %ld / nout %ld: this build needs %d / %d", path, h->nin,
                             h->nout, LATENT_NIN, LATENT_NOUT);
    h->d = latent_decoder_alloc((int)h->nz, (int)h->layers, (int)h->width, (size_t)h->nmat);
    if (!h->d)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: shape nz %ld, layers %ld, width %ld out of range (nz 1..%d, "
                             "layers 1..%d, width %d..%d)",
                             path, h->nz, h->layers, h->width, LATENT_MAX_NZ, LATENT_MAX_LAYERS,
                             LATENT_NOUT, LATENT_MAX_WIDTH);
    return 0;
}

/* A 'material NAME' line: the next training material's name. */
static int header_material(struct decoder_header *h, const char *val, struct gonio_err *err)
{
    const char *path = h->path;
    if (!h->d || h->m >= h->d->n_materials)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: 'material %s' outside the declared materials list", path, val);
    if (strlen(val) >= LATENT_NAME_MAX || strchr(val, ' '))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: material name '%s' invalid", path, val);
    strcpy(h->d->names[h->m++], val);
    return 0;
}

/* The 'data N CRC' line and the weights and latents after it, bytes
 * [pos, len) of buf: exactly N little-endian doubles, all finite. */
static int read_data(struct decoder_header *h, const char *val, const char *buf, size_t len,
                     size_t pos, struct gonio_err *err)
{
    const char *path = h->path;
    latent_decoder *d = h->d;
    if (!d || h->m != d->n_materials)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: data before the full materials list (%zu of %ld names)", path,
                             h->m, h->nmat);
    unsigned long long n;
    unsigned crc;
    char tail;
    if (sscanf(val, "%llu %8x%c", &n, &crc, &tail) != 2)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: malformed data line '%s'", path, val);
    size_t want = d->n_params + d->n_materials * (size_t)d->nz;
    if (n != want)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: data holds %llu values, the shape needs %zu", path, n, want);
    if (len - pos != 8 * want)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: %zu data bytes after the header, expected %zu (truncated or "
                             "extended file)",
                             path, len - pos, 8 * want);
    const unsigned char *b = (const unsigned char *)buf + pos;
    if (crc_of(b, 8 * want) != crc)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: data CRC mismatch (file damaged)", path);
    for (size_t i = 0; i < want; i++) {
        double v = get_le64(b + 8 * i);
        if (!isfinite(v))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: data value %zu is not finite", path,
                                 i);
        if (i < d->n_params)
            d->params[i] = v;
        else
            d->latents[i - d->n_params] = v;
    }
    return 0;
}

/* The training options the header recorded, on the loaded decoder. */
static void set_training(latent_decoder *d, const struct decoder_header *h)
{
    d->train = latent_train_default_options();
    d->train.nz = d->nz;
    d->train.layers = d->layers;
    d->train.width = d->width;
    d->train.seed = (uint64_t)h->seed;
    d->train.steps = h->steps;
    d->train.samples_per_step = (int)h->sps;
    d->train.lr = h->lr;
    d->train.lr_z = h->lr_z;
    d->train.lambda_z = h->lambda_z;
    d->train.z_noise = h->z_noise;
    d->train.inplane = h->inplane;
}

/* The header lines after the magic one, up to and including 'data' and
 * the binary block it announces. */
static int read_header(struct decoder_header *h, const char *buf, size_t len, size_t pos,
                       struct gonio_err *err)
{
    char key[64], val[1024];
    for (;;) {
        size_t line_start = pos;
        if (next_line(buf, len, &pos, key, sizeof key, val, sizeof val) < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: malformed header line at byte %zu",
                                 h->path, line_start);
        int rc = header_setting(h, key, val, err);
        if (rc < 0)
            return rc;
        if (rc > 0)
            continue;
        if (!strcmp(key, "materials"))
            rc = header_materials(h, val, err);
        else if (!strcmp(key, "material"))
            rc = header_material(h, val, err);
        else if (!strcmp(key, "data"))
            return read_data(h, val, buf, len, pos, err);
        else
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s: unknown header key '%s'", h->path, key);
        if (rc < 0)
            return rc;
    }
}

latent_decoder *latent_decoder_load(const char *path, struct gonio_err *err)
{
    size_t len = 0, pos = 0;
    char *buf = read_all(path, &len, err);
    if (!buf)
        return NULL;
    char key[64], val[1024];
    struct decoder_header h = {.path = path, .nin = -1, .nz = -1, .layers = -1, .width = -1,
                               .nout = -1, .nmat = -1};
    if (next_line(buf, len, &pos, key, sizeof key, val, sizeof val) < 0 ||
        strcmp(key, LATENT_MAGIC) != 0)
        gonio_err_set(err, GONIO_EBADDATA,
                      "%s: not a gonio latent decoder file (first line must be '%s %d')", path,
                      LATENT_MAGIC, LATENT_FILE_VERSION);
    else if (strcmp(val, "1") != 0)
        gonio_err_set(err, GONIO_EBADDATA,
                      "%s: decoder file version '%s' not supported (this build reads %d)", path,
                      val, LATENT_FILE_VERSION);
    else if (read_header(&h, buf, len, pos, err) == 0) {
        set_training(h.d, &h);
        latent_decoder_refresh(h.d);
        free(buf);
        return h.d;
    }
    latent_decoder_free(h.d);
    free(buf);
    return NULL;
}

int latent_decoder_default_path(char *buf, size_t size)
{
    int r = snprintf(buf, size, "%s/models/latent-decoder.gld", gonio_config_dir());
    return r < 0 || (size_t)r >= size ? -ENAMETOOLONG : 0;
}

int latent_decoder_nz(const latent_decoder *d) { return d->nz; }
size_t latent_decoder_n_materials(const latent_decoder *d) { return d->n_materials; }
uint32_t latent_decoder_crc(const latent_decoder *d) { return d->crc; }
double latent_decoder_prior_bandwidth(const latent_decoder *d) { return d->prior_h; }
uint64_t latent_decoder_seed(const latent_decoder *d) { return d->train.seed; }
const double *latent_decoder_mean_latent(const latent_decoder *d) { return d->mean; }

const char *latent_decoder_material(const latent_decoder *d, size_t i)
{
    return i < d->n_materials ? d->names[i] : NULL;
}

const double *latent_decoder_latent(const latent_decoder *d, size_t i)
{
    return i < d->n_materials ? d->latents + i * (size_t)d->nz : NULL;
}

long latent_decoder_find(const latent_decoder *d, const char *name)
{
    for (size_t i = 0; i < d->n_materials; i++)
        if (!strcmp(d->names[i], name))
            return (long)i;
    return -1;
}

void latent_decoder_eval(const latent_decoder *d, const double *z, const struct brdf_pair *pairs,
                         size_t n, double *rgb)
{
    enum { BLOCK = 256 };
    double x[LATENT_NIN * BLOCK], o[LATENT_NOUT * BLOCK];
    for (size_t i = 0; i < n; i += BLOCK) {
        size_t nb = n - i < BLOCK ? n - i : BLOCK;
        for (size_t k = 0; k < nb; k++)
            latent_encode(&pairs[i + k], x + LATENT_NIN * k);
        latent_net_forward(d, z, nb, x, o);
        for (size_t k = 0; k < LATENT_NOUT * nb; k++) {
            double f = expm1(o[k]);
            rgb[LATENT_NOUT * i + k] = f > 0 ? f : 0.0;
        }
    }
}

/* A material owns a copy of the network (no training latents) and its z. */
struct latent_mat {
    latent_decoder *d;
    double z[LATENT_MAX_NZ];
    double scale;
};

static void latent_mat_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                            double *rgb)
{
    const struct latent_mat *lm = priv;
    latent_decoder_eval(lm->d, lm->z, pairs, n, rgb);
    if (lm->scale != 1.0)
        for (size_t k = 0; k < 3 * n; k++)
            rgb[k] *= lm->scale;
}

static void latent_mat_free(void *priv)
{
    struct latent_mat *lm = priv;
    if (lm)
        latent_decoder_free(lm->d);
    free(lm);
}

static const struct brdf_material_ops latent_ops = {
    .kind = "latent",
    .eval = latent_mat_eval,
    .free_priv = latent_mat_free,
};

brdf_material *latent_material(const latent_decoder *d, const double *z, const char *name)
{
    return latent_material_scaled(d, z, 1.0, name);
}

brdf_material *latent_material_scaled(const latent_decoder *d, const double *z, double scale,
                                      const char *name)
{
    struct latent_mat *lm = calloc(1, sizeof *lm);
    if (!lm)
        return NULL;
    lm->d = latent_decoder_alloc(d->nz, d->layers, d->width, 0);
    if (!lm->d) {
        free(lm);
        return NULL;
    }
    memcpy(lm->d->params, d->params, d->n_params * sizeof *d->params);
    memcpy(lm->d->mean, d->mean, (size_t)d->nz * sizeof *d->mean);
    lm->d->train = d->train;
    lm->d->crc = d->crc;
    memcpy(lm->z, z, (size_t)d->nz * sizeof *z);
    lm->scale = scale;
    return brdf_material_new(&latent_ops, lm, name ? name : "latent");
}
