#include "cli/request_file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/paths.h"
#include "daemon/request.h"

int request_file_attach(json_t *req, const char *field, const char *opt, const char *value)
{
    if (!gonio_ref_is_file(value)) {
        json_object_set_new(req, field, json_string(value));
        return 0;
    }
    FILE *f = fopen(value, "rb");
    if (!f) {
        fprintf(stderr, "gonio capture: %s '%s': cannot read: %s\n", opt, value,
                strerror(errno));
        return 2;
    }
    /* One byte past the limit tells a file that is too large. */
    char *text = malloc(CONTROL_FILE_MAX + 1);
    size_t n = text ? fread(text, 1, CONTROL_FILE_MAX + 1, f) : 0;
    int failed = !text || ferror(f);
    fclose(f);
    if (failed) {
        fprintf(stderr, "gonio capture: %s '%s': cannot read\n", opt, value);
        free(text);
        return 2;
    }
    if (n > CONTROL_FILE_MAX) {
        fprintf(stderr,
                "gonio capture: %s '%s': larger than %d bytes, the most a file sent to "
                "goniod may hold\n",
                opt, value, CONTROL_FILE_MAX);
        free(text);
        return 2;
    }
    /* JSON text is UTF-8: a file that is not cannot travel as it is. */
    json_t *s = memchr(text, 0, n) ? NULL : json_stringn(text, n);
    free(text);
    if (!s) {
        fprintf(stderr, "gonio capture: %s '%s': not UTF-8 text\n", opt, value);
        return 2;
    }
    char key[32];
    snprintf(key, sizeof key, "%s_text", field);
    json_object_set_new(req, field, json_string(value));
    json_object_set_new(req, key, s);
    return 0;
}

int request_file_fits(json_t *req)
{
    char *text = json_dumps(req, JSON_COMPACT);
    size_t len = text ? strlen(text) : 0;
    free(text);
    /* the id conn_request adds: a few bytes more */
    if (len + 32 <= CONTROL_MAX_LINE)
        return 0;
    fprintf(stderr,
            "gonio capture: the request with its files is %zu bytes, more than the %d of "
            "goniod's request line; send smaller files\n",
            len, CONTROL_MAX_LINE);
    return 2;
}
