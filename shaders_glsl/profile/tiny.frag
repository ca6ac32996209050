#version 460
// Draw overhead: the point of draw i writes i + 1, so a readback shows every draw landed.
layout(location = 0) flat in uint v_id;
layout(location = 0) out uint o_id;

void main() { o_id = v_id + 1u; }
