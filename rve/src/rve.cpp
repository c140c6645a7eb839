// placeholder until the rve library lands
namespace softhom::rve { int placeholder() { return 0; } }
