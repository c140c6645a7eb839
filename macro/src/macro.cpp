// placeholder until the macro library lands
namespace softhom::macro { int placeholder() { return 0; } }
