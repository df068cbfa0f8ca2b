// sinh.glsl: hyperbolic sine/cosine accurate near 0 (the GLSL built-ins compute
// (e^t - e^-t)/2 and lose all relative precision for small t, which the KM
// reflectance R = sinh t / (...) of thin paint needs).
float sinh_acc(float t) {
    if (abs(t) < 0.25) {
        float t2 = t * t;
        return t * (1.0 + t2 * (1.0 / 6.0 + t2 * (1.0 / 120.0 + t2 * (1.0 / 5040.0
                  + t2 * (1.0 / 362880.0)))));
    }
    float e = exp(t);
    return 0.5 * (e - 1.0 / e);
}
float cosh_acc(float t) {
    float e = exp(t);
    return 0.5 * (e + 1.0 / e);
}
