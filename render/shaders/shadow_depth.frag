#version 460
// Shadow depth pass: only the depth of the nearest hair fragment matters (colour writes off).
void main() {
}
