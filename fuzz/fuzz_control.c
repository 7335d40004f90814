/* Control-socket requests (daemon/request.h): one JSON line from any local
 * client allowed on the socket. */
#include <string.h>

#include "daemon/request.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct control_request rq;
    const char *code = NULL;
    char msg[1024];
    msg[0] = 0;
    int rc = control_request_parse((const char *)data, size, &rq, &code, msg, sizeof msg);
    if (rc == 0) {
        FUZZ_CHECK(rq.doc && json_is_object(rq.doc) && rq.name);
        FUZZ_CHECK(!strcmp(control_cmd_name(rq.cmd), rq.name));
    } else {
        FUZZ_CHECK(code && msg[0] && memchr(msg, 0, sizeof msg));
    }
    /* The id is echoed in replies: it must be a string or an integer. */
    FUZZ_CHECK(!rq.id || json_is_string(rq.id) || json_is_integer(rq.id));
    control_request_free(&rq);
    return 0;
}
