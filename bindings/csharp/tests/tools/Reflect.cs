// Reads a compiled assembly by reflection for the CI checks (never shipped):
//   mono Reflect.exe types   Locd.dll   every public top-level type: "namespace name arity"
//   mono Reflect.exe pinvoke Locd.dll   every [DllImport]: "library entrypoint", one per line
// Loading an assembly this way runs none of its code and loads no native library.
using System;
using System.Linq;
using System.Reflection;
using System.Runtime.InteropServices;

static class Reflect
{
    static int Main(string[] args)
    {
        if (args.Length != 2 || (args[0] != "types" && args[0] != "pinvoke")) {
            Console.Error.WriteLine("usage: Reflect.exe types|pinvoke ASSEMBLY");
            return 2;
        }
        Assembly a = Assembly.LoadFrom(args[1]);
        if (args[0] == "types") {
            foreach (Type t in a.GetExportedTypes().Where(t => !t.IsNested).OrderBy(t => t.FullName)) {
                string name = t.Name;
                int tick = name.IndexOf('`');
                if (tick >= 0)
                    name = name.Substring(0, tick);
                Console.WriteLine("{0} {1} {2}", t.Namespace ?? "-", name, t.GetGenericArguments().Length);
            }
            return 0;
        }
        const BindingFlags all = BindingFlags.Public | BindingFlags.NonPublic | BindingFlags.Static | BindingFlags.Instance
                                 | BindingFlags.DeclaredOnly;
        foreach (Type t in a.GetTypes())
            foreach (MethodInfo m in t.GetMethods(all)) {
                if ((m.Attributes & MethodAttributes.PinvokeImpl) == 0)
                    continue;
                var d = (DllImportAttribute)m.GetCustomAttributes(typeof(DllImportAttribute), false).FirstOrDefault();
                if (d == null)
                    throw new Exception("no DllImportAttribute on " + t.FullName + "." + m.Name);
                Console.WriteLine("{0} {1}", d.Value, string.IsNullOrEmpty(d.EntryPoint) ? m.Name : d.EntryPoint);
            }
        return 0;
    }
}
